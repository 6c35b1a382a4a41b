"""The first call of a law's loop in a process holds a lock shared by every process using the
same numba cache (interfacelaw/_kernels.py, ``cache_lock``): numba's cache lets two processes
that write new overloads of one function at once name each other's machine code in its index
(a verification sweep's two workers did: the next run loaded the wrong loop and segfaulted).
No numba compile here: the loop is a plain Python stand-in, the lock is what is checked."""
import threading
import time

from interfacelaw import _kernels


def test_a_first_call_waits_for_the_cache_lock():
    calls = []

    def loop(x):                       # stands in for a compiled loop: records when it runs
        calls.append(time.monotonic())
        return x

    held, release = threading.Event(), threading.Event()

    def holder():                      # another process compiling: the same lock file
        with _kernels.cache_lock():
            held.set()
            release.wait(5.0)
            # the time is taken while the lock is still held: the first call can only run
            # after it (taken after the with block, a loaded host let the waiting call run
            # before this thread recorded it: 0.26 ms "early" in one CI run)
            released.append(time.monotonic())

    released = []
    t = threading.Thread(target=holder)
    t.start()
    assert held.wait(5.0)
    worker = threading.Thread(target=lambda: _kernels.call(loop, ("test", 1), 7))
    worker.start()
    time.sleep(0.3)
    assert calls == [], "the first call ran while another holder had the compile lock"
    release.set()
    worker.join(5.0)
    t.join(5.0)
    assert len(calls) == 1 and calls[0] >= released[0]
    # a second call of the same loop and key takes no lock (compiled in this process)
    with _kernels.cache_lock():
        assert _kernels.call(loop, ("test", 1), 8) == 8
    assert len(calls) == 2


def test_a_first_call_drops_llvm_remarks_and_keeps_the_rest(capfd):
    """LLVM writes "remark: ... loop not vectorized: ..." to the C stderr (file descriptor 2)
    while a loop compiles with the forced vector width: 9 lines on examples/ex01's first call
    with a cold cache. A first call drops those lines and passes on everything else written
    there, in order (a stand-in loop writes both kinds with os.write, as LLVM does)."""
    import os

    def loop(x):
        os.write(2, b"remark: <unknown>:0:0: loop not vectorized: call instruction cannot "
                    b"be vectorized\n")
        os.write(2, b"an LLVM error line\n")
        os.write(2, b"remark: <unknown>:0:0: loop not vectorized: value that could not be "
                    b"identified as reduction is used outside the loop\n")
        os.write(2, b"remark: something else\n")
        return x

    assert _kernels.call(loop, ("test", 2), 5) == 5
    err = capfd.readouterr().err
    assert err == "an LLVM error line\nremark: something else\n", err
