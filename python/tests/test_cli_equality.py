"""The Python call gives the CLI's result, method by method (the same
library underneath: equal to the last bit of the OBJ text)."""

import subprocess

import numpy as np
import pytest

import normalnet

CASES = [
    ("normalnet", ["--iterations", "2", "--vertex-iterations", "3"], {"iterations": 2, "vertex_iterations": 3}),
    ("gnf", [], {}),
    ("bnf", ["--sigma-r", "0.3"], {"sigma_r": 0.3}),
    ("sun07", [], {}),
    ("l0", ["--lambda", "0.1"], {"lambda_over_le2": 0.1}),
    ("bi", [], {}),
    ("vt", [], {}),
    ("cnr", ["--vertex-iterations", "10"], {"vertex_iterations": 10}),
    ("oracle", ["--iterations", "3"], {"iterations": 3}),
]


@pytest.mark.parametrize("method,flags,params", CASES, ids=[c[0] for c in CASES])
def test_python_equals_cli(method, flags, params, cli, tmp_path, example):
    v, f, cv, cf = example
    from conftest import ROOT

    out_cli = tmp_path / "cli.obj"
    cmd = [cli, "denoise", "-q", str(ROOT / "examples" / "noisy-part.obj"), str(out_cli), "-m", method, *flags]
    if method == "oracle":
        cmd += ["--gt", str(ROOT / "examples" / "clean-part.obj")]
    subprocess.run(cmd, check=True, capture_output=True, env={"PATH": "/usr/bin:/bin"})
    gt = (cv, cf) if method == "oracle" else None
    ours = normalnet.denoise(v, f, method, gt=gt, **params)
    out_py = tmp_path / "py.obj"
    normalnet.write_mesh(out_py, ours, f)
    assert out_py.read_text() == out_cli.read_text(), method
    # and the arrays agree with what the CLI wrote, read back
    cv2, _ = normalnet.read_mesh(out_cli)
    np.testing.assert_array_equal(cv2, normalnet.read_mesh(out_py)[0])
