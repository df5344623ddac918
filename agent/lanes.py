"""A dot product in four lanes, as vector code, in the order the learners' sums are defined.

`lane_dot(x, y)` is `sum_i x_i y_i` summed in four partial sums, lane k taking the terms
with `i % 4 == k` in increasing i (the last `n % 4` terms go to lane 0), the lanes combined
as `(s0 + s1) + (s2 + s3)`. That fixed order lets the CPU overlap the additions, which a
single running sum makes wait for each other, and it is the order of every linear learner's
Q (`agent.linear.action_value`), of the C learner (`agent.sarsa_c`) and of every result
computed so far.

Numba compiles four scalar partial sums as four scalar chains: its LLVM passes do not pack
them into one vector (the SLP vectorizer, which would, is off in numba for miscompilations
it once made), and the loop vectorizer may not reorder a sum without fast-math. So
`lane_sums` writes the loop in LLVM IR with one `<4 x double>` accumulator: each step
multiplies four `x_i` by four `y_i` and adds the products lane by lane, the same
multiplications and additions in the same order as the scalar code (no fused multiply-add:
the product is rounded, then added), so every result is the same to the bit
(`tests/test_lanes.py`).
"""

from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic, register_jitable

LANES = 4
"""Partial sums of a dot product."""


def _contiguous_float64(array) -> bool:
    return (isinstance(array, types.Array) and array.ndim == 1 and array.layout == "C"
            and array.dtype == types.float64)


@intrinsic
def lane_sums(typingctx, x, y):
    """The four partial sums `(s0, s1, s2, s3)`, `s_k = sum_m x[4m + k] y[4m + k]` over the
    first `4 (n // 4)` terms, of two contiguous float64 vectors of length n (`y` at least as
    long as `x`)."""
    if not (_contiguous_float64(x) and _contiguous_float64(y)):
        return None
    signature = types.UniTuple(types.float64, LANES)(x, y)

    def codegen(context, builder, signature, args):
        first = context.make_array(signature.args[0])(context, builder, args[0])
        second = context.make_array(signature.args[1])(context, builder, args[1])
        length = builder.extract_value(first.shape, 0)
        vector = ir.VectorType(ir.DoubleType(), LANES)
        lanes = ir.Constant(length.type, LANES)
        total = cgutils.alloca_once_value(builder, ir.Constant(vector, [0.0] * LANES))
        with cgutils.for_range(builder, builder.sdiv(length, lanes)) as loop:
            offset = builder.mul(loop.index, lanes)
            x_k = builder.load(builder.bitcast(builder.gep(first.data, [offset]),
                                               vector.as_pointer()), align=8)
            y_k = builder.load(builder.bitcast(builder.gep(second.data, [offset]),
                                               vector.as_pointer()), align=8)
            builder.store(builder.fadd(builder.load(total), builder.fmul(x_k, y_k)), total)
        sums = builder.load(total)
        return context.make_tuple(builder, signature.return_type,
                                  [builder.extract_element(sums, ir.Constant(ir.IntType(32), k))
                                   for k in range(LANES)])

    return signature, codegen


@register_jitable
def lane_dot(x, y):
    """`sum_i x_i y_i` over the length of `x` in the lanes' order (see the module's
    docstring); `x` and `y` contiguous float64 vectors, `y` at least as long."""
    n = x.shape[0]
    s0, s1, s2, s3 = lane_sums(x, y)
    for i in range(n - n % LANES, n):
        s0 += x[i] * y[i]
    return (s0 + s1) + (s2 + s3)
