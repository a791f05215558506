"""pointfair.smooth and pointfair.curvature against the command, their inputs, threads,
progress and interruption."""
import os
import signal
import threading
import time
import unittest

import numpy as np

import pointfair
from support import Folder, assert_same_bits, run_cli


class SmoothMatchesCommand(Folder):
    """smooth() gives the bits `pointfair smooth` writes, for the same input and options."""

    def check(self, py_options, cli_options, shape="cube"):
        source = self.generated(shape)
        out = self.path("cli.ply")
        run_cli("smooth", source, out, "--quiet", *cli_options)
        expected = pointfair.read(out)["xyz"]
        actual = pointfair.smooth(pointfair.read(source)["xyz"], **py_options)
        assert_same_bits(self, actual, expected)

    def test_defaults(self):
        self.check({}, [])

    def test_paper(self):
        self.check({"paper": True, "steps": 8}, ["--paper", "--steps", "8"])

    def test_options(self):
        self.check({"k": 20, "cutoff": "continuous", "tau": 0.6, "lambda_schedule": "once", "steps": 6,
                    "quadric_finish": False, "move": "free", "normal": "pca", "eps": float("inf")},
                   ["--k", "20", "--cutoff", "continuous", "--tau", "0.6", "--lambda-schedule", "once",
                    "--steps", "6", "--no-quadric-finish", "--move", "free", "--normal", "pca", "--eps", "inf"],
                   shape="sphere")

    def test_robust_gate(self):
        self.check({"robust_gate": 0, "steps": 6}, ["--robust-gate", "0", "--steps", "6"])

    def test_fit_sharing(self):
        self.check({"quadric_share": 1, "steps": 4}, ["--quadric-share", "1", "--steps", "4"])
        self.check({"quadric_share": 8, "quadric_share_turn": 0.05, "steps": 4},
                   ["--quadric-share", "8", "--quadric-share-turn", "0.05", "--steps", "4"])

    def test_momentum(self):
        self.check({"momentum": 0.7, "steps": 6}, ["--momentum", "0.7", "--steps", "6"])
        self.check({"momentum": 0.7, "momentum_gate": 0, "steps": 6},
                   ["--momentum", "0.7", "--momentum-gate", "0", "--steps", "6"])

    def test_finish_options_and_lambda(self):
        self.check({"quadric_k": 40, "quadric_passes": 1, "lambda": 5.0, "steps": 4},
                   ["--quadric-k", "40", "--quadric-passes", "1", "--lambda", "5", "--steps", "4"])

    def test_neighbors_from(self):
        source = self.generated("sphere")
        reference = self.generated("sphere", noise=0.1, name="reference.ply")
        out = self.path("cli.ply")
        run_cli("smooth", source, out, "--quiet", "--steps", "5", "--neighbors-from", reference)
        actual = pointfair.smooth(pointfair.read(source)["xyz"], steps=5,
                                  neighbors_from=pointfair.read(reference)["xyz"])
        assert_same_bits(self, actual, pointfair.read(out)["xyz"])


class CurvatureMatchesCommand(Folder):
    """curvature() gives what `pointfair curvature` writes (the file stores float32)."""

    def test_attributes(self):
        source = self.generated("cube")
        out = self.path("cli.ply")
        run_cli("curvature", source, out, "--quiet", "--k", "24")
        cli = pointfair.read(out)
        got = pointfair.curvature(pointfair.read(source)["xyz"], k=24)
        self.assertEqual(got["k"], 24)
        self.assertEqual(got["feature_class"].dtype, np.uint8)
        for name in ("k1", "k2", "mean_curvature", "laplacian_norm", "feature_class"):
            column = cli["scalar_" + name]
            self.assertEqual(got[name].shape, (len(column),))
            assert_same_bits(self, got[name].astype(column.dtype), column)
        for name, columns in (("normals", ("nx", "ny", "nz")),
                              ("d1", ("scalar_d1x", "scalar_d1y", "scalar_d1z")),
                              ("d2", ("scalar_d2x", "scalar_d2y", "scalar_d2z"))):
            for axis, column in enumerate(columns):
                assert_same_bits(self, got[name][:, axis].astype(cli[column].dtype), cli[column])
        # A cube has edges and corners, and its faces are flat.
        self.assertEqual(set(np.unique(got["feature_class"])), {0, 1, 2})

    def test_sphere_curvature(self):
        # Radius 1, outward normals: k1, k2 and H near +1.
        xyz = pointfair.read(self.generated("sphere", noise=0.0))["xyz"]
        got = pointfair.curvature(xyz)
        self.assertAlmostEqual(float(np.median(got["mean_curvature"])), 1.0, delta=0.05)
        self.assertGreater(float(np.median(np.einsum("ij,ij->i", got["normals"], xyz))), 0.99)


class Inputs(unittest.TestCase):
    def setUp(self):
        rng = np.random.default_rng(7)
        self.xyz = rng.normal(size=(500, 3))
        self.xyz /= np.linalg.norm(self.xyz, axis=1)[:, None]

    def test_contiguous_float64_read_in_place(self):
        self.assertEqual(pointfair._pointfair._points_address(self.xyz), self.xyz.ctypes.data)

    def test_strided_input_copied_with_same_result(self):
        wide = np.zeros((len(self.xyz), 6))
        wide[:, ::2] = self.xyz  # every other column: not contiguous
        view = wide[:, ::2]
        self.assertFalse(view.flags["C_CONTIGUOUS"])
        self.assertNotEqual(pointfair._pointfair._points_address(view), view.ctypes.data)
        fortran = np.asfortranarray(self.xyz)
        expected = pointfair.smooth(self.xyz, steps=3)
        assert_same_bits(self, pointfair.smooth(view, steps=3), expected)
        assert_same_bits(self, pointfair.smooth(fortran, steps=3), expected)

    def test_input_untouched_and_output_new(self):
        before = self.xyz.copy()
        out = pointfair.smooth(self.xyz, steps=3)
        assert_same_bits(self, self.xyz, before)
        self.assertEqual(out.shape, self.xyz.shape)
        self.assertEqual(out.dtype, np.float64)
        self.assertTrue(out.flags["C_CONTIGUOUS"])
        self.assertFalse(np.shares_memory(out, self.xyz))
        self.assertFalse(np.array_equal(out, self.xyz))

    def test_list_input(self):
        assert_same_bits(self, pointfair.smooth(self.xyz.tolist(), steps=2), pointfair.smooth(self.xyz, steps=2))

    def test_steps_zero_reproduces(self):
        assert_same_bits(self, pointfair.smooth(self.xyz, steps=0, quadric_finish=False), self.xyz)

    def test_threads_give_same_bits(self):
        assert_same_bits(self, pointfair.smooth(self.xyz, steps=4, threads=1),
                         pointfair.smooth(self.xyz, steps=4, threads=2))


class Errors(unittest.TestCase):
    def setUp(self):
        self.xyz = np.random.default_rng(3).normal(size=(200, 3))

    def assert_value_error(self, pattern, call, *args, **kwargs):
        with self.assertRaisesRegex(ValueError, pattern) as caught:
            call(*args, **kwargs)
        self.assertIsInstance(caught.exception, pointfair.ParamError)

    def test_dtype(self):
        self.assert_value_error("points: expected dtype float64, got float32", pointfair.smooth,
                                self.xyz.astype(np.float32))
        self.assert_value_error("points: expected dtype float64, got int64", pointfair.curvature,
                                self.xyz.astype(np.int64))
        self.assert_value_error("expected dtype float64, got >f8", pointfair.smooth, self.xyz.astype(">f8"))

    def test_shape(self):
        self.assert_value_error(r"points: expected an array of shape \(N, 3\), got shape \(200, 2\)",
                                pointfair.smooth, self.xyz[:, :2].copy())
        self.assert_value_error(r"got shape \(600,\)", pointfair.smooth, self.xyz.ravel())
        self.assert_value_error(r"got shape \(2, 100, 3\)", pointfair.curvature, self.xyz.reshape(2, 100, 3))

    def test_not_finite(self):
        bad = self.xyz.copy()
        bad[5, 1] = np.nan
        self.assert_value_error("points: point 5", pointfair.smooth, bad)

    def test_unknown_option(self):
        self.assert_value_error("pointfair.smooth: unknown option 'kk'", pointfair.smooth, self.xyz, kk=3)
        self.assert_value_error("unknown option 'quadric_k'", pointfair.curvature, self.xyz, quadric_k=3)
        self.assert_value_error("unknown option 'json'", pointfair.smooth, self.xyz, json=True)
        self.assert_value_error("unknown option 'colour_by'", pointfair.smooth, self.xyz, colour_by="kmax")

    def test_bad_values(self):
        self.assert_value_error("--steps expects a whole number, got 'many'", pointfair.smooth, self.xyz,
                                steps="many")
        self.assert_value_error("--cutoff must be one of sharp, continuous, got 'soft'", pointfair.smooth,
                                self.xyz, cutoff="soft")
        self.assert_value_error("tau", pointfair.smooth, self.xyz, tau=3.0)
        self.assert_value_error("--k must be 1..1024 or 'auto'", pointfair.smooth, self.xyz, k=0)
        self.assert_value_error("k: expected a value, got a bool", pointfair.smooth, self.xyz, k=True)
        self.assert_value_error("feature_gated: expected True or False", pointfair.smooth, self.xyz,
                                feature_gated=1)
        self.assert_value_error("k: expected a number or a string, got list", pointfair.smooth, self.xyz,
                                k=[3])
        self.assert_value_error("--threads must be >= 0", pointfair.smooth, self.xyz, threads=-1)
        self.assert_value_error("progress must be callable", pointfair.smooth, self.xyz, progress=3)
        self.assert_value_error("neighbors_from: has 10 points, points has 200", pointfair.smooth, self.xyz,
                                neighbors_from=self.xyz[:10].copy())


class ProgressAndInterruption(unittest.TestCase):
    def setUp(self):
        rng = np.random.default_rng(11)
        self.xyz = rng.normal(size=(3000, 3))
        self.xyz /= np.linalg.norm(self.xyz, axis=1)[:, None]
        self.xyz += rng.normal(scale=0.01, size=self.xyz.shape)

    def test_progress_reports_steps_and_finish(self):
        calls = []
        pointfair.smooth(self.xyz, steps=5, stop_lambda_ratio=0, stop_plateau=0,
                         progress=lambda stage, done, total: calls.append((stage, done, total)))
        steps = [c for c in calls if c[0] == "steps"]
        self.assertEqual(steps, [("steps", i, 5) for i in range(1, 6)])
        finish = [c for c in calls if c[0] == "finish"]
        self.assertTrue(finish)
        self.assertEqual(finish[-1][1], finish[-1][2])
        self.assertEqual({c[0] for c in calls}, {"steps", "finish"})

    def test_exception_in_progress_stops_the_run(self):
        class Enough(Exception):
            pass

        calls = []

        def progress(stage, done, total):
            calls.append(done)
            if done == 3:
                raise Enough("stop at 3")

        with self.assertRaisesRegex(Enough, "stop at 3"):
            pointfair.smooth(self.xyz, steps=50, stop_lambda_ratio=0, stop_plateau=0, progress=progress)
        self.assertEqual(calls, [1, 2, 3])
        # The module works as before afterwards.
        self.assertEqual(pointfair.smooth(self.xyz, steps=1).shape, self.xyz.shape)

    def test_sigint_interrupts_a_run(self):
        # A run of many steps; SIGINT from another thread after 0.5 s: KeyboardInterrupt, soon.
        pid = os.getpid()
        timer = threading.Timer(0.5, lambda: os.kill(pid, signal.SIGINT))
        start = time.monotonic()
        timer.start()
        try:
            with self.assertRaises(KeyboardInterrupt):
                pointfair.smooth(self.xyz, steps=100000, stop_lambda_ratio=0, stop_plateau=0,
                                 quadric_finish=False)
        finally:
            timer.cancel()
        self.assertLess(time.monotonic() - start, 30.0)

    def test_gil_released_while_running(self):
        # While smooth() runs in a thread, this thread keeps running Python code.
        result = {}
        worker = threading.Thread(target=lambda: result.setdefault(
            "xyz", pointfair.smooth(self.xyz, steps=30, stop_lambda_ratio=0, stop_plateau=0)))
        ticks = 0
        worker.start()
        time.sleep(0.05)
        while worker.is_alive():
            ticks += 1
            time.sleep(0.001)
        worker.join()
        self.assertIn("xyz", result)
        self.assertGreater(ticks, 20)


if __name__ == "__main__":
    unittest.main()
