"""Shared fixtures: the fdv program, the real recordings, one short simulated dataset per session
and its `fdv run` results (the independent expectation the Python side is checked against)."""
import json
import os
import subprocess
from pathlib import Path

import pytest

import fdv

REPO = Path(__file__).resolve().parents[2]
REAL_DATA = Path(os.environ.get("FDV_REAL_DATA_DIR", REPO.parent / "shared" / "data" / "real"))
FDV_CLI = os.environ.get("FDV_CLI", str(REPO / "build" / "fdv"))


def real_file(name):
    """Path of a real recording in ../shared/data/real; skipped when absent, unless
    FDV_REQUIRE_REAL_DATA=1 (CI) makes that a failure (as the C++ tests do)."""
    path = REAL_DATA / name
    if not path.exists():
        if os.environ.get("FDV_REQUIRE_REAL_DATA") == "1":
            pytest.fail(f"missing real recording {path}")
        pytest.skip(f"real recording not found: {path}")
    return str(path)


def cli(*args, check=True):
    """Runs the fdv program; returns the completed process (stdout, stderr as text)."""
    return subprocess.run([FDV_CLI, *map(str, args)], capture_output=True, text=True, check=check)


def cli_json(*args):
    return json.loads(cli(*args).stdout)


def read_jsonl(path):
    with open(path) as f:
        return [json.loads(line) for line in f]


@pytest.fixture(scope="session")
def workdir(tmp_path_factory):
    return tmp_path_factory.mktemp("fdv_python")


@pytest.fixture(scope="session")
def dataset(workdir):
    """A short simulated throw (0.6 s at 346x260: a few seconds to simulate): the ball is seen,
    tracked and estimated in 3D."""
    out = workdir / "scene2_ball"
    fdv.simulate("scene2_ball", seed=3, out=str(out), duration=0.6, resolution=(346, 260))
    return out


@pytest.fixture(scope="session")
def cli_results(dataset, workdir):
    """`fdv run --visualize` over the dataset."""
    out = workdir / "cli_run"
    cli("run", dataset, "--out", out, "--visualize")
    return out
