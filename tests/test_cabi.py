"""The C ABI (interfacelaw/cabi.py): the numba cfunc called through ctypes, as a C
host calls it, against InterfaceLaw.evaluate.

Tolerance of the comparisons: the C function runs the same compiled kernel
(``_kernels.evaluate_serial``) as ``InterfaceLaw.evaluate``, so the numbers agree to round-off;
measured bit-identical. 1e-13 relative (plus 1e-13 of the array's scale for entries that are
zero in one of them) leaves room for a different instruction selection (FMA contraction) of
the same expressions, and is still ~1e9 times smaller than any modelling difference.
"""
from __future__ import annotations

import ctypes
import shutil
import subprocess
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from interfacelaw import (CohesiveParams, ContactParams, DamageParams, FrictionParams,
                          InterfaceLaw, cabi)

P = ctypes.POINTER(ctypes.c_double)
COH = CohesiveParams.from_fracture_energy(3e6, 2e6, 250.0, 0.2, 1.5)   # l_Tc != l_Nc


def ptr(a: np.ndarray):
    assert a.dtype == np.float64 and a.flags.c_contiguous
    return a.ctypes.data_as(P)


def call(fn, law, gap, state, dt=1.0):
    """One C call: the host's own output buffers, pointers only. Returns (rc, F, T, state)."""
    n, dim = gap.shape
    F, T = np.full((n, dim), np.nan), np.full((n, dim, dim), np.nan)
    new = [np.full(n, np.nan) for _ in range(3)] + [np.full((n, dim - 1), np.nan),
                                                     np.full(n, np.nan)]
    params = cabi.pack_params(law)
    rc = fn(n, dim, ptr(params), dt, ptr(np.ascontiguousarray(gap)),
            *(ptr(getattr(state, k)) for k in ("kappa", "damage", "separation", "slip",
                                               "dissipated")),
            ptr(F), ptr(T), *(ptr(a) for a in new))
    return rc, F, T, type(state)(*new)


def c_function(law):
    """The cfunc's raw address cast to the C prototype by ctypes (no numba wrapper used)."""
    return cabi.ctypes_prototype()(cabi.evaluate_cfunc(law).address)


def assert_same(a, b):
    scale = max(np.abs(b).max(), 1e-300)
    np.testing.assert_allclose(a, b, rtol=1e-13, atol=1e-13 * scale)


def random_walk(law, fn, dim, n=200, steps=25, dt=None, seed=0):
    """Drive n points along random gap walks (opening, closing into contact, sliding), committing
    every step in both the C and the Python path, and compare every output at every step."""
    rng = np.random.default_rng(seed)
    lref = np.array([COH.l_Nc] + [COH.l_Tc] * (dim - 1))
    st_c = st_py = law.initial_state(n, dim)
    gap = np.zeros((n, dim))
    for _ in range(steps):
        gap = gap + rng.normal(scale=0.15, size=(n, dim)) * lref
        F, T, st_py = law.evaluate(gap, st_py, dt=dt)
        rc, Fc, Tc, st_c = call(fn, law, gap, st_c, 1.0 if dt is None else dt)
        assert rc == cabi.OK
        assert_same(Fc, F)
        assert_same(Tc, T)
        for k in ("kappa", "damage", "separation", "slip", "dissipated"):
            assert_same(getattr(st_c, k), getattr(st_py, k))
    return st_py


@pytest.fixture(scope="module")
def full_law():
    return InterfaceLaw(COH, ContactParams("rough"), FrictionParams(0.3),
                        DamageParams(g_max=6.67e-4, alpha=2.0))


@pytest.mark.parametrize("dim", [2, 3])
def test_full_law_matches_evaluate_along_random_walks(full_law, dim):
    st = random_walk(full_law, c_function(full_law), dim)
    # the walks reach every branch the comparison is meant to cover
    assert st.debonded.any() and (~st.debonded).any()
    assert (st.damage > 0).any() and np.abs(st.slip).max() > 0


@pytest.mark.parametrize("form", ["objective", "rate"])
def test_damage_forms_and_linear_contact_share_the_compiled_function(full_law, form):
    law = InterfaceLaw(COH, ContactParams("linear"), FrictionParams(0.5),
                       DamageParams(g_max=6.67e-4, alpha=2.0, form=form, t_ref=0.5))
    assert cabi.evaluate_cfunc(law) is cabi.evaluate_cfunc(full_law)   # runtime parameters
    random_walk(law, c_function(law), 3, dt=0.02 if form == "rate" else None, seed=1)


def test_cohesive_only_law_copies_the_slip(full_law):
    law = InterfaceLaw(COH)
    fn = c_function(law)
    assert cabi.evaluate_cfunc(law) is not cabi.evaluate_cfunc(full_law)
    random_walk(law, fn, 2, seed=2)
    st = law.initial_state(3, 3)
    st = type(st)(st.kappa, st.damage, st.separation, np.full((3, 2), 7e-5), st.dissipated)
    rc, _, _, new = call(fn, law, np.full((3, 3), 1e-5), st)
    assert rc == cabi.OK and np.array_equal(new.slip, st.slip)      # no friction: unchanged


def test_errors_are_return_codes_and_write_nothing(full_law):
    fn = c_function(full_law)
    st = full_law.initial_state(4, 2)
    gap = np.full((4, 2), 1e-5)
    P_ = cabi.pack_params(full_law)
    assert fn(4, 4, ptr(P_), 1.0, ptr(gap), *(ptr(np.zeros(16)) for _ in range(12))) \
        == cabi.BAD_SHAPE
    for bad in (np.nan, np.inf, 2 * cabi.GAP_LIMIT):
        g = gap.copy()
        g[2, 1] = bad
        rc, F, _, new = call(fn, full_law, g, st)
        assert rc == cabi.BAD_GAP and np.isnan(F).all() and np.isnan(new.kappa).all()
    rate = InterfaceLaw(COH, ContactParams(), FrictionParams(),
                        DamageParams(g_max=1e-3, alpha=2.0, form="rate"))
    for dt in (0.0, -1.0, np.nan, np.inf):
        rc, F, _, _ = call(c_function(rate), rate, gap, st, dt=dt)
        assert rc == cabi.BAD_DT and np.isnan(F).all()
    # the other forms ignore dt, as InterfaceLaw.evaluate does
    assert call(fn, full_law, gap, st, dt=np.nan)[0] == cabi.OK


def test_pack_params_layout(full_law):
    p = cabi.pack_params(full_law)
    assert p.shape == (cabi.PARAMS_SIZE,)
    o = cabi.OFFSETS
    assert p[o[0]] == COH.sigma_max and p[o[0] + 2] == COH.l_Nc        # cohesive block
    assert p[o[2]] == 0.3                                               # friction f
    assert p[o[3] + 2] == 6.67e-4                                       # damage g_max
    assert p[-1] == 0.0                                                 # no dt needed
    q = cabi.pack_params(InterfaceLaw(COH))
    assert np.all(q[o[1]:] == 0.0)                                      # absent parts
    with pytest.raises(ValueError, match="InterfaceLaw"):
        cabi.pack_params("law")


def test_concurrent_calls_from_threads(full_law):
    """ctypes releases the GIL during the call: four host threads run the function at once on
    disjoint chunks; the result is that of one call on everything (no shared state)."""
    fn = c_function(full_law)
    rng = np.random.default_rng(3)
    n = 40_000
    gap = rng.normal(size=(n, 3)) * COH.l_Nc
    st = full_law.initial_state(n, 3)
    rc, F, T, _ = call(fn, full_law, gap, st)
    chunks = np.array_split(np.arange(n), 4)
    with ThreadPoolExecutor(4) as ex:
        parts = list(ex.map(lambda c: call(fn, full_law, gap[c], st.take(c)), chunks))
    assert rc == 0 and all(p[0] == 0 for p in parts)
    assert np.array_equal(np.concatenate([p[1] for p in parts]), F)
    assert np.array_equal(np.concatenate([p[2] for p in parts]), T)


HOST_C = r"""
#include <stdint.h>
typedef int32_t (*law_fn)(int64_t, int64_t, const double *, double, const double *,
                          const double *, const double *, const double *, const double *,
                          const double *, double *, double *, double *, double *, double *,
                          double *, double *);

/* A C host: one point opened in mode I to g_end in nsteps increments, each step committed
   (the trial state copied over the committed one). Returns the dissipated energy per unit
   area, or -rc on an error; *peak = the largest normal traction. */
double mode_I(law_fn f, const double *params, double g_end, int nsteps, double *peak)
{
    double gap[2] = {0.0, 0.0}, kappa = 0, damage = 0, sep = 0, slip = 0, diss = 0;
    double F[2], T[4], kn, dn, sn, sln, dsn;
    *peak = 0.0;
    for (int k = 1; k <= nsteps; ++k) {
        gap[0] = g_end * k / nsteps;
        int32_t rc = f(1, 2, params, 1.0, gap, &kappa, &damage, &sep, &slip, &diss,
                       F, T, &kn, &dn, &sn, &sln, &dsn);
        if (rc != 0) return -rc;
        kappa = kn; damage = dn; sep = sn; slip = sln; diss = dsn;          /* commit */
        if (F[0] > *peak) *peak = F[0];
    }
    return diss;
}
"""


def test_a_c_host_calls_the_function_pointer(tmp_path):
    """A compiled C library receives the function pointer and drives a point itself."""
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.skip("no C compiler")
    (tmp_path / "host.c").write_text(HOST_C)
    lib = tmp_path / "libhost.so"
    subprocess.run([cc, "-O2", "-shared", "-fPIC", "-o", str(lib), str(tmp_path / "host.c")],
                   check=True)
    host = ctypes.CDLL(str(lib))
    host.mode_I.restype = ctypes.c_double
    host.mode_I.argtypes = [ctypes.c_void_p, P, ctypes.c_double, ctypes.c_int, P]
    law = InterfaceLaw(COH)
    params = cabi.pack_params(law)
    peak = ctypes.c_double()
    D = host.mode_I(cabi.evaluate_cfunc(law).address, ptr(params), 1.5 * COH.l_Nc, 150,
                    ctypes.byref(peak))
    # mode I: the work of separation is G_I exactly for any number of increments
    # (docs/law.md §3; 1e-10 = the rounding of 150 additions); the peak sigma_max is reached
    # on the increment at lambda_max = 0.2 (the 20th of 150): 1e-12
    assert D == pytest.approx(COH.G_I, rel=1e-10)
    assert peak.value == pytest.approx(COH.sigma_max, rel=1e-12)


EMBED_C = r"""
#include <Python.h>
#include <stdint.h>
#include <stdio.h>
typedef int32_t (*law_fn)(int64_t, int64_t, const double *, double, const double *,
                          const double *, const double *, const double *, const double *,
                          const double *, double *, double *, double *, double *, double *,
                          double *, double *);

/* A native program (no Python around it): it starts an embedded interpreter once to build the
   law and get the function pointer, then drives one point in mode I in plain C, with the GIL
   released (the C function needs neither the GIL nor any Python object). */
int main(void)
{
    Py_Initialize();
    if (PyRun_SimpleString(
            "from interfacelaw import CohesiveParams, InterfaceLaw, cabi\n"
            "law = InterfaceLaw(CohesiveParams.from_fracture_energy(3e6, 2e6, 250.0, 0.2, 1.5))\n"
            "address = cabi.evaluate_cfunc(law).address\n"
            "params = cabi.pack_params(law).tolist()\n") != 0)
        return 2;
    PyObject *main = PyImport_AddModule("__main__");
    PyObject *addr = PyObject_GetAttrString(main, "address");
    PyObject *plist = PyObject_GetAttrString(main, "params");
    law_fn f = (law_fn)PyLong_AsVoidPtr(addr);
    double params[256];
    Py_ssize_t np_ = PyList_Size(plist);
    if (np_ > 256) return 3;
    for (Py_ssize_t i = 0; i < np_; ++i) params[i] = PyFloat_AsDouble(PyList_GetItem(plist, i));

    double gap[2] = {0.0, 0.0}, kappa = 0, damage = 0, sep = 0, slip = 0, diss = 0, peak = 0;
    double F[2], T[4], kn, dn, sn, sln, dsn;
    double l_Nc = params[2];                           /* the cohesive block: sigma, tau, l_Nc */
    int32_t rc = 0;
    Py_BEGIN_ALLOW_THREADS
    for (int k = 1; k <= 150 && rc == 0; ++k) {
        gap[0] = 1.5 * l_Nc * k / 150;
        rc = f(1, 2, params, 1.0, gap, &kappa, &damage, &sep, &slip, &diss,
               F, T, &kn, &dn, &sn, &sln, &dsn);
        kappa = kn; damage = dn; sep = sn; slip = sln; diss = dsn;          /* commit */
        if (F[0] > peak) peak = F[0];
    }
    Py_END_ALLOW_THREADS
    printf("%d %.17g %.17g\n", rc, diss, peak);
    Py_DECREF(addr);
    Py_DECREF(plist);
    return Py_FinalizeEx() < 0 ? 4 : 0;
}
"""


def test_a_native_program_embedding_python_calls_the_law(tmp_path):
    """What a C or Fortran code does: embed Python once, take the pointer, loop in C."""
    import os
    import sys
    import sysconfig
    from pathlib import Path

    cc = shutil.which("cc") or shutil.which("gcc")
    inc, libdir = sysconfig.get_paths()["include"], sysconfig.get_config_var("LIBDIR")
    ver = sysconfig.get_config_var("LDVERSION") or sysconfig.get_python_version()
    if cc is None or not (Path(inc) / "Python.h").exists() or not libdir \
            or not sysconfig.get_config_var("Py_ENABLE_SHARED"):
        pytest.skip("no C compiler, Python headers or shared libpython")
    (tmp_path / "host.c").write_text(EMBED_C)
    exe = tmp_path / "host"
    subprocess.run([cc, "-O2", str(tmp_path / "host.c"), f"-I{inc}", f"-L{libdir}",
                    f"-lpython{ver}", f"-Wl,-rpath,{libdir}", "-o", str(exe)], check=True)
    root = Path(__file__).resolve().parents[1]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(root)] + [p for p in sys.path if p.endswith("site-packages")]))
    # generous timeout: a cold numba cache compiles the kernel first (minutes when loaded)
    out = subprocess.run([str(exe)], env=env, capture_output=True, text=True, timeout=1200)
    assert out.returncode == 0, out.stderr
    rc, D, peak = out.stdout.split()
    # as in the ctypes C host: G_I exactly (1e-10: rounding of 150 additions), peak sigma_max
    # on the increment at lambda_max (1e-12)
    assert int(rc) == 0
    assert float(D) == pytest.approx(COH.G_I, rel=1e-10)
    assert float(peak) == pytest.approx(COH.sigma_max, rel=1e-12)
