"""How the compiled loops are called: context tuples whose numba type is worked out once.

numba's dispatcher fingerprints arrays and tuples of arrays in C, but a tuple holding a structref
(the compiled pieces' bundle, :mod:`lieint.fast.pieces`) falls back to typing the whole tuple in
Python, about 25 µs at each call of a loop (up to three a run: the first trial step, the
controller loop, the fixed-step loop). :func:`typed_context` hands the engine a
:class:`TypedContext` instead, typed by one attribute read.
"""

from __future__ import annotations

from functools import cache

import numpy as np

__all__ = ["TypedContext", "typed_context"]


class TypedContext(tuple):
    """A layout's context tuple whose class carries its numba type (:func:`typed_context`)."""

    __slots__ = ()
    _numba_type_ = None


def _item_key(item):
    """What fixes an item's numba type: a structref proxy's type, an array's dtype, dimensions,
    layout and writeability, else the item's class."""
    if isinstance(item, np.ndarray):
        order = "C" if item.flags.c_contiguous else ("F" if item.flags.f_contiguous else "A")
        return ("array", item.dtype.str, item.ndim, order, item.flags.writeable)
    numba_type = getattr(item, "_type", None)
    if numba_type is not None:  # a structref proxy (the compiled pieces' bundle)
        return ("struct", numba_type)
    return ("object", type(item))


#: the TypedContext class of each kind of context (the items' keys)
_CONTEXT_CLASSES: dict = {}


def typed_context(ctx):
    """``ctx`` as a :class:`TypedContext` whose numba type is worked out once per kind of context:
    typed by one attribute read (its class's ``_numba_type_``, registered with
    :func:`numba.extending.typeof_impl` in :func:`_register`) and unboxed as any tuple. Other
    contexts (0, tuples of arrays, which numba types in C) are returned as they are."""
    if not isinstance(ctx, tuple) or isinstance(ctx, TypedContext):
        return ctx
    key = tuple(_item_key(item) for item in ctx)
    if not any(k[0] == "struct" for k in key):
        return ctx  # typed in C already
    cls = _CONTEXT_CLASSES.get(key)
    if cls is None:
        import numba

        _register()
        cls = _CONTEXT_CLASSES[key] = type("TypedContext", (TypedContext,), {"_numba_type_": numba.typeof(ctx)})
    return cls(ctx)


@cache
def _register() -> None:
    from numba.extending import typeof_impl

    @typeof_impl.register(TypedContext)
    def _typeof_typed_context(val, c):
        return type(val)._numba_type_
