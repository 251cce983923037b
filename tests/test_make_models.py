"""assets/make_models.py runs with only the project's dependencies and rebuilds the committed
models."""

import subprocess
import sys

import numpy as np
import trimesh

from tests.helpers import ASSETS

# trimesh imports these lazily for some repairs; neither is a dependency of the project.
NOT_DEPENDENCIES = ("scipy", "networkx")


def test_make_models_runs_without_scipy_and_matches_the_committed_models(tmp_path):
    script = ASSETS / "make_models.py"
    code = ("import runpy, sys\n"
            + "".join(f"sys.modules[{name!r}] = None\n" for name in NOT_DEPENDENCIES)
            + f"sys.argv = [{str(script)!r}, '--out', {str(tmp_path)!r}]\n"
            + f"runpy.run_path({str(script)!r}, run_name='__main__')\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=tmp_path, timeout=120)
    assert done.returncode == 0, done.stderr
    for name in ("arch.obj", "house.glb"):
        made = trimesh.load(tmp_path / name, force="mesh", process=False)
        committed = trimesh.load(ASSETS / "models" / name, force="mesh", process=False)
        assert len(made.faces) == len(committed.faces), name
        assert np.allclose(made.bounds, committed.bounds), name
        assert made.is_winding_consistent, name
        # Signed: faces wound inwards would flip it.
        assert np.isclose(made.volume, committed.volume) and made.volume > 0, name
