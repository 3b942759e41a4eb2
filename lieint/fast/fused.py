"""An explicit fused multiply-add for compiled kernels: ``fma(a, b, c) = a·b + c`` rounded once.

Why explicit. Letting the compiler contract ``a * b + c`` (``fastmath={"contract"}``) would make
the rounding depend on which instructions it chose where: the SIMD body of a loop and its scalar
remainder may contract differently, and so a body's result would depend on its position in an
ensemble (and on how a sweep cut the ensemble into chunks). ``llvm.fma`` is IEEE 754's
fusedMultiplyAdd, correctly rounded by definition, the same in a scalar register and in every
lane of a vector: kernels written with it keep strict, position-independent arithmetic and still
get one instruction (and one rounding) per multiply-add on processors with FMA units.
"""

from __future__ import annotations

from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

__all__ = ["fma"]


@intrinsic
def fma(typingctx, a, b, c):
    """``a * b + c`` with a single rounding (``llvm.fma.f64``), for float64 arguments."""
    if not all(isinstance(x, types.Float) for x in (a, b, c)):
        return None
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        args = [context.cast(builder, v, t, types.float64) for v, t in zip(args, signature.args, strict=True)]
        double = ir.DoubleType()
        fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(double, [double] * 3), "llvm.fma.f64")
        return builder.call(fn, args)

    return sig, codegen
