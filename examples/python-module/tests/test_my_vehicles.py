"""`my_vehicles`, a user's crate made a Python module with one macro call,
against the command lines of the crates it is made of (roller-racer,
steering) in the same build. Run by `cargo test` (tests/pytest.rs).
"""

import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

import my_vehicles

BIN_DIR = Path(os.environ["EZY_BIN_DIR"])


def cli(program, *args):
    p = subprocess.run([str(BIN_DIR / program), *args], capture_output=True, text=True)
    return p.returncode, p.stdout, p.stderr


def trajectory(out):
    path = Path(out) / "trajectory.csv"
    with open(path) as f:
        columns = f.readline().strip().split(",")
    return columns, np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)


def test_the_users_model_effect_and_scenes_are_there():
    assert "roller_racer" in my_vehicles.models()
    assert "ezyroller" in my_vehicles.models()  # the built-ins come along
    scenes = my_vehicles.scenes()
    assert "roller" in scenes and "steer" in scenes and "drive" in scenes
    assert my_vehicles.check("roller_racer", states=2).passed
    assert "roller" in my_vehicles.equations("roller_racer").text.lower()


def test_the_users_model_runs_as_its_command_line(tmp_path):
    r = my_vehicles.run("roller", t_end=2.0, every=0.1)
    code, _, err = cli("roller-racer", "run", "roller", "--t-end", "2", "--every", "0.1", "--no-figures",
                       "--out", str(tmp_path))
    assert code == 0, err
    columns, table = trajectory(tmp_path)
    assert r.columns == columns and np.array_equal(r.data, table)
    assert r.plot("paths").axes[0].get_title().startswith("Paths")


def test_the_users_force_law_runs_and_is_changed_by_name(tmp_path):
    s = my_vehicles.scene("steer")
    assert s.effects["steer"].k == 20.0 and s.effects["steer"].c == 0.5
    s.effects["steer"].c = 0.8
    r = s.run(t_end=2.0, every=0.1)
    # the law's work column closes the energy ledger as a built-in's does
    assert "W_steer" in r.columns
    gap = np.abs(r["T"] - r["T"][0] - r["W"])
    assert gap.max() < 1e-8
    code, _, err = cli("steering", "run", "steer", "--t-end", "2", "--every", "0.1", "--set", "steer.c=0.8",
                       "--no-figures", "--out", str(tmp_path))
    assert code == 0, err
    columns, table = trajectory(tmp_path)
    assert r.columns == columns and np.array_equal(r.data, table)
    # refused when set, with the message the command line's run gives
    with pytest.raises(my_vehicles.EzyError) as e:
        s.effects["steer"].bogus = 1.0
    code, _, err = cli("steering", "run", "steer", "--set", "steer.bogus=1", "--out", str(tmp_path / "x"))
    assert code != 0 and err == f"error: {e.value}\n"
    assert s.sets == [("steer.c", 0.8)]
