"""Atomic writes (interfacelaw.atomic): the file under its final name has the mode the
process's umask gives a newly created file (0o666 & ~umask), not the 0o600 of the temporary
file it was written to, so results are readable by the group/others as with open()."""
import os
import stat
import subprocess
import sys

import pytest


@pytest.mark.parametrize("umask, mode", [(0o022, 0o644), (0o027, 0o640), (0o077, 0o600)])
def test_atomic_write_has_the_umask_mode(tmp_path, umask, mode):
    target = tmp_path / "out" / "f.json"
    code = (f"import os; os.umask({umask:#o}); "
            "from interfacelaw.atomic import atomic_write_text; "
            f"atomic_write_text({str(target)!r}, 'x')")
    subprocess.run([sys.executable, "-c", code], check=True)
    assert target.read_text() == "x"
    assert stat.S_IMODE(os.stat(target).st_mode) == mode
    assert [p.name for p in target.parent.iterdir()] == ["f.json"]   # no temporary left
