"""numpy in and out: shapes, dtypes, errors that say what is wrong."""

import numpy as np
import pytest

import normalnet


def test_read_write_round_trip(tmp_path, example):
    v, f, _, _ = example
    assert v.dtype == np.float64 and v.shape == (782, 3)
    assert f.dtype == np.int64 and f.shape == (1560, 3)
    for suffix in (".obj", ".ply", ".off", ".stl"):
        path = tmp_path / f"m{suffix}"
        normalnet.write_mesh(path, v, f)
        v2, f2 = normalnet.read_mesh(path)
        if suffix == ".stl":  # STL stores triangles; vertices are merged back
            assert f2.shape == f.shape
            continue
        np.testing.assert_array_equal(f2, f)
        np.testing.assert_allclose(v2, v, rtol=0, atol=1e-6 if suffix == ".ply" else 0)


def test_other_dtypes_are_converted(example):
    v, f, _, _ = example
    a = normalnet.denoise(v, f, "gnf")
    b = normalnet.denoise(v.astype(np.float32).astype(np.float64), f.astype(np.int32), "gnf")
    c = normalnet.denoise(v.tolist(), f.tolist(), "gnf")
    np.testing.assert_array_equal(a, c)
    assert b.shape == a.shape and b.dtype == np.float64


def test_bad_arrays_are_clear_value_errors(example):
    v, f, _, _ = example
    with pytest.raises(ValueError, match=r"vertices: expected shape \(N, 3\), got \(782, 2\)"):
        normalnet.denoise(v[:, :2], f, "gnf")
    with pytest.raises(ValueError, match="faces: expected an integer array"):
        normalnet.denoise(v, f.astype(np.float64), "gnf")
    with pytest.raises(ValueError, match=r"faces: expected shape \(M, 3\)"):
        normalnet.denoise(v, f[:, :2], "gnf")
    bad = f.copy()
    bad[7, 1] = 10_000
    with pytest.raises(ValueError, match=r"faces\[7\].*10000.*outside"):
        normalnet.denoise(v, bad, "gnf")
    with pytest.raises(ValueError, match="unknown method"):
        normalnet.denoise(v, f, "median")
    with pytest.raises(ValueError, match="unknown parameter `mu`.*mu_g"):
        normalnet.denoise(v, f, "gnf", mu=0.3)
    with pytest.raises(ValueError, match="mu_g"):
        normalnet.denoise(v, f, "gnf", mu_g=-1.0)
    with pytest.raises(ValueError, match="`mu_g` = nan: not a finite number"):
        normalnet.denoise(v, f, "gnf", mu_g=float("nan"))
    with pytest.raises(ValueError, match="ground truth"):
        normalnet.denoise(v, f, "oracle")
    with pytest.raises(OSError, match="no-such.obj"):
        normalnet.read_mesh("/tmp/no-such.obj")


def test_parameters_noise_metrics_render(example, tmp_path):
    v, f, cv, cf = example
    out, params, stages = normalnet.denoise_report(v, f, "gnf", normal_iterations=3)
    assert params["normal_iterations"] == 3 and stages is None
    names = [m["name"] for m in normalnet.methods()]
    assert names[0] == "normalnet" and "gnf" in names and "oracle" in names
    m = normalnet.metrics((cv, cf), (out, f))
    m_noisy = normalnet.metrics((cv, cf), v)
    assert m["e_a_deg"] < m_noisy["e_a_deg"]
    for key in ("e_a_deg", "e_v", "e_v_over_le", "hausdorff", "flipped_faces"):
        assert key in m
    n1 = normalnet.noise(cv, cf, level=0.3, seed=4)
    n2 = normalnet.noise(cv, cf, level=0.3, seed=4)
    np.testing.assert_array_equal(n1, n2)
    assert not np.array_equal(n1, normalnet.noise(cv, cf, level=0.3, seed=5))
    img = normalnet.render(out, f, gt=(cv, cf), size=(320, 240))
    assert img.shape == (240, 320, 3) and img.dtype == np.uint8 and img.std() > 10
    normalnet.render_png(tmp_path / "r.png", out, f, size=(64, 48))
    assert (tmp_path / "r.png").read_bytes()[:4] == b"\x89PNG"


def test_oracle_and_normalnet_run(example):
    v, f, cv, cf = example
    o = normalnet.denoise(v, f, "oracle", gt=(cv, cf), iterations=2)
    assert o.shape == v.shape
    out, params, stages = normalnet.denoise_report(v, f, iterations=1, vertex_iterations=2)
    assert params["model"] == "<built-in models/lite>"
    assert stages["faces_processed"] == f.shape[0]
    assert np.isfinite(out).all() and not np.array_equal(out, v)
