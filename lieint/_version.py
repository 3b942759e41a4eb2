"""The package's version, in a module of its own: the run files, sweep stores and study notes
record it, and the modules that write them import it from here, not from the package above them."""

__version__ = "0.2.0"
