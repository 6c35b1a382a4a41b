"""C ABI of the interface law: a numba ``cfunc`` with a plain C signature on pointers.

What a C, C++ or Fortran host calls (docs/using_the_law.md has the whole calling convention)::

    int32_t interfacelaw_evaluate(
        int64_t n, int64_t dim,          /* points; 2 (g_N, g_T) or 3 (g_N, g_T1, g_T2)  */
        const double *params,            /* PARAMS_SIZE doubles: pack_params(law)          */
        double dt,                       /* step's time increment [s] (rate damage form)   */
        const double *gap,               /* [n][dim] total gap at the end of the step [m]  */
        const double *kappa,             /* [n]   committed state (start of the step) ...  */
        const double *damage,            /* [n]                                            */
        const double *separation,        /* [n]                                            */
        const double *slip,              /* [n][dim-1]                                     */
        const double *dissipated,        /* [n]   ... never written                        */
        double *traction,                /* [n][dim]        out                            */
        double *tangent,                 /* [n][dim][dim]   out, d traction_a / d gap_b    */
        double *kappa_new, double *damage_new, double *separation_new,
        double *slip_new,                /* [n][dim-1]      out: the trial state           */
        double *dissipated_new);         /* [n]             out                            */
    /* returns 0 on success; 1 bad n or dim, 2 a gap not finite or beyond GAP_LIMIT,
       3 dt not > 0 and finite for the rate damage form: nothing is written then */

All arrays are C-contiguous (row-major) float64 and must not overlap (the new state must not be
the committed one). The function runs the point law of ``InterfaceLaw.evaluate``
(``interfacelaw._kernels._law``) in the kernel's generic scalar loop
``interfacelaw._kernels.evaluate_serial`` (one compiled loop for both dims and every parameter
value; not the vectorised loops ``InterfaceLaw`` uses), so it returns the same numbers
(tests/test_cabi.py: to round-off, measured bit-identical); it runs serially and keeps no
state: a host may call it from several threads on disjoint arrays at once.

Which optional parts (contact, friction, damage) the law has is fixed at compile time, as in
``InterfaceLaw``: :func:`evaluate_cfunc` compiles one function per combination (cached per
process). Getting the address needs Python and numba in the process (numba compiles at run
time with LLVM); see docs/using_the_law.md for what works without Python and what does not.
"""
from __future__ import annotations

import ctypes
import functools

import numpy as np
from numba import carray, cfunc, njit, types
from numba.np.unsafe.ndarray import to_fixed_tuple

from . import _kernels
from .law import GAP_LIMIT, InterfaceLaw
from .params import CohesiveParams, ContactParams, DamageParams, FrictionParams

__all__ = ["PARAMS_SIZE", "OFFSETS", "C_SIGNATURE", "pack_params", "evaluate_cfunc",
           "ctypes_prototype", "OK", "BAD_SHAPE", "BAD_GAP", "BAD_DT"]

OK, BAD_SHAPE, BAD_GAP, BAD_DT = 0, 1, 2, 3


def _part_sizes() -> tuple[int, int, int, int]:
    """Lengths of the kernel's parameter tuples (cohesive, contact, friction, damage), read
    from a law with every part, so the layout follows the kernel if the tuples change."""
    law = InterfaceLaw(CohesiveParams(1.0, 1.0, 1.0, 1.0, 0.5), ContactParams(),
                       FrictionParams(), DamageParams(g_max=1.0))
    return tuple(len(t) for t in law.kernel_params)


_SIZES = _part_sizes()
#: start of each block in ``params``: cohesive, contact, friction, damage, then one slot t_ref
OFFSETS = tuple(int(o) for o in np.concatenate([[0], np.cumsum(_SIZES)]))
PARAMS_SIZE = OFFSETS[-1] + 1
_T_REF = OFFSETS[-1]

_D = types.CPointer(types.float64)
C_SIGNATURE = types.int32(types.int64, types.int64, _D, types.float64, _D,
                          _D, _D, _D, _D, _D,
                          _D, _D, _D, _D, _D, _D, _D)


def pack_params(law: InterfaceLaw) -> np.ndarray:
    """The ``params`` array of the C function for ``law`` (float64, PARAMS_SIZE).

    Blocks at OFFSETS: the kernel's cohesive, contact, friction and damage tuples (the derived
    constants of docs/law.md, as ``InterfaceLaw`` computes them; zeros for an absent
    part), then t_ref [s] when the law needs dt (damage form "rate"), else 0."""
    if not isinstance(law, InterfaceLaw):
        raise ValueError(f"pack_params law = {law!r} is not allowed; allowed: an InterfaceLaw")
    p = np.zeros(PARAMS_SIZE)
    for off, t in zip(OFFSETS, law.kernel_params):
        if t is not None:
            p[off:off + len(t)] = t
    p[_T_REF] = law.damage.t_ref if law.needs_dt else 0.0
    return p


def _block(off: int, size: int, present: bool):
    """njit getter of one parameter block as a fixed tuple (or None: the part is absent, and
    the kernel compiled for it does not contain that part)."""
    if not present:
        return njit(inline="always")(lambda p: None)
    return njit(inline="always")(lambda p: to_fixed_tuple(p[off:off + size], size))


@functools.lru_cache(maxsize=None)
def _compile(contact: bool, friction: bool, damage: bool):
    coh_of = _block(OFFSETS[0], _SIZES[0], True)
    con_of = _block(OFFSETS[1], _SIZES[1], contact)
    fri_of = _block(OFFSETS[2], _SIZES[2], friction)
    dmg_of = _block(OFFSETS[3], _SIZES[3], damage)
    npar, t_ref_at, limit = PARAMS_SIZE, _T_REF, GAP_LIMIT
    kernel = _kernels.evaluate_serial

    @cfunc(C_SIGNATURE, nopython=True)
    def interfacelaw_evaluate(n, dim, params, dt, gap, kappa, dmg, sep, slip, diss,
                              F, T, kappa_n, dmg_n, sep_n, slip_n, diss_n):
        if n < 0 or (dim != 2 and dim != 3):
            return 1
        p = carray(params, npar)
        t_ref = p[t_ref_at]
        rdt = 1.0
        if t_ref > 0.0:                          # the rate damage form: rdt = dt / t_ref
            rdt = dt / t_ref
            if not (dt > 0.0 and rdt > 0.0 and rdt < np.inf):
                return 3
        g = carray(gap, (n, dim))
        for i in range(n):                       # one pass: also catches NaN and inf
            for a in range(dim):
                if not abs(g[i, a]) <= limit:
                    return 2
        s = carray(slip, (n, dim - 1))
        s_n = carray(slip_n, (n, dim - 1))
        if not friction:         # the kernel leaves the slip alone then (loops: a slice
            for i in range(n):   # assignment costs ~15 s more to compile)
                for a in range(dim - 1):
                    s_n[i, a] = s[i, a]
        kernel(g, coh_of(p), con_of(p), fri_of(p), dmg_of(p), rdt,
               carray(kappa, n), carray(dmg, n), carray(sep, n), s, carray(diss, n),
               carray(F, (n, dim)), carray(T, (n, dim, dim)),
               carray(kappa_n, n), carray(dmg_n, n), carray(sep_n, n), s_n, carray(diss_n, n))
        return 0

    return interfacelaw_evaluate


def evaluate_cfunc(law: InterfaceLaw):
    """The compiled C function for ``law``'s combination of parts (a numba ``CFunc``:
    ``.address`` is the C function pointer, ``.ctypes`` a ctypes wrapper). Pass it
    ``pack_params(law)``. Compiled once per combination and process (a few seconds)."""
    if not isinstance(law, InterfaceLaw):
        raise ValueError(f"evaluate_cfunc law = {law!r} is not allowed; allowed: an "
                         "InterfaceLaw")
    return _compile(law.contact is not None, law.friction is not None,
                    law.damage is not None)


def ctypes_prototype():
    """The ctypes function type of the C signature (what a ctypes caller casts the address to)."""
    P = ctypes.POINTER(ctypes.c_double)
    return ctypes.CFUNCTYPE(ctypes.c_int32, ctypes.c_int64, ctypes.c_int64, P, ctypes.c_double,
                            P, P, P, P, P, P, P, P, P, P, P, P, P)
