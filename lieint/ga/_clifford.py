"""clifford, the one dependency of :mod:`lieint.ga`: imported first, so that a missing clifford
is reported as the extra that installs it (``pip install "lieint[ga]"``)."""

from .._optional import require

clifford = require("clifford", "lieint.ga (geometric algebra)")
