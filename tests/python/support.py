"""Shared pieces of the Python module's tests: the built command (POINTFAIR_EXE, set by
CMake) and small generated clouds in a temporary folder."""
import os
import subprocess
import tempfile
import unittest

import numpy as np

import pointfair

EXE = os.environ.get("POINTFAIR_EXE", "pointfair")


def run_cli(*args):
    """Runs the command; returns its stdout. Fails the test on a non-zero exit."""
    done = subprocess.run([EXE, *map(str, args)], capture_output=True, text=True)
    if done.returncode != 0:
        raise AssertionError(f"pointfair {' '.join(map(str, args))} exited {done.returncode}: {done.stderr}")
    return done.stdout


class Folder(unittest.TestCase):
    """A test case with a temporary folder (self.path(name)) removed afterwards."""

    def setUp(self):
        self._folder = tempfile.TemporaryDirectory(prefix="pointfair-python-")

    def tearDown(self):
        self._folder.cleanup()

    def path(self, name):
        return os.path.join(self._folder.name, name)

    def generated(self, shape="cube", points=3000, noise=0.5, name=None, seed=1):
        """A noisy sample of `shape` written by `pointfair generate`, as positions only (PLY,
        float64), so that no input normals steer the output's orientation. Returns the path."""
        raw = self.path(f"raw-{shape}-{points}-{seed}.ply")
        run_cli("generate", shape, raw, "--points", points, "--noise", noise, "--seed", seed)
        xyz = pointfair.read(raw)["xyz"]
        out = self.path(name or f"{shape}-{points}-{seed}.ply")
        pointfair.write(out, {"xyz": xyz})
        return out


def assert_same_bits(test, actual, expected):
    """Same shape, dtype and bytes (so 0.0 and -0.0 differ too)."""
    test.assertEqual(actual.shape, expected.shape)
    test.assertEqual(actual.dtype, expected.dtype)
    if np.ascontiguousarray(actual).tobytes() != np.ascontiguousarray(expected).tobytes():
        diff = np.abs(actual.astype(np.float64) - expected.astype(np.float64))
        test.fail(f"arrays differ in {int(np.count_nonzero(diff))} of {diff.size} values, "
                  f"by at most {np.nanmax(diff):.3g}")
