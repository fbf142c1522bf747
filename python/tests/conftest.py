"""Shared fixtures: the repository's example meshes, the `normalnet` CLI
binary (``$NORMALNET_BIN``, else ``target/release`` or ``target/debug``)."""

import os
import pathlib
import shutil

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def example():
    import normalnet

    v, f = normalnet.read_mesh(ROOT / "examples" / "noisy-part.obj")
    cv, cf = normalnet.read_mesh(ROOT / "examples" / "clean-part.obj")
    return v, f, cv, cf


@pytest.fixture(scope="session")
def cli():
    candidates = [os.environ.get("NORMALNET_BIN")] + [
        str(ROOT / "target" / p / "normalnet") for p in ("release", "debug")
    ]
    for c in candidates:
        if c and os.path.isfile(c) and os.access(c, os.X_OK):
            return c
    found = shutil.which("normalnet")
    if found:
        return found
    pytest.skip("no normalnet binary: build it (cargo build --release) or set NORMALNET_BIN")
