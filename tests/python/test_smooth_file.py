"""pointfair.smooth_file against `pointfair smooth ... --json`: the same file and summary, in core
and out of core."""
import json
import os
import signal
import unittest

import numpy as np

import pointfair
from support import Folder, assert_same_bits, run_cli

# Keys whose values are times or rates, or (out of core) depend on how the pipeline's threads
# met: present in both, values differ run to run (the command's too).
TIMED = {"seconds", "point_steps_per_second", "peak_accounted_bytes", "tiles_in_flight"}


def same_keys(a, b):
    if isinstance(a, dict) and isinstance(b, dict):
        return sorted(a) == sorted(b) and all(same_keys(a[k], b[k]) for k in a)
    return not isinstance(a, dict) and not isinstance(b, dict)


class Compared(Folder):
    """run_both: smooth_file and the command on the same input, with the same options."""

    def run_both(self, source, extension, cli_options, py_options):
        cli_out, py_out = self.path("cli" + extension), self.path("py" + extension)
        cli = json.loads(run_cli("smooth", source, cli_out, "--quiet", "--json", *cli_options))
        report = pointfair.smooth_file(source, py_out, **py_options)
        self.assertTrue(same_keys(report, cli), f"{sorted(report)} vs {sorted(cli)}")
        for key in cli:
            if key not in TIMED and key not in ("output", "threads"):
                self.assertEqual(report[key], cli[key], key)
        self.assertEqual(report["output"], py_out)
        cli_cloud, py_cloud = pointfair.read(cli_out), pointfair.read(py_out)
        self.assertEqual(list(py_cloud), list(cli_cloud))
        for name in cli_cloud:
            assert_same_bits(self, py_cloud[name], cli_cloud[name])
        return report, py_cloud


class SmoothFile(Compared):
    def test_same_file_and_report(self):
        source = self.generated("cube")
        report, _ = self.run_both(source, ".ply", ["--steps", "6"], {"steps": 6})
        self.assertEqual(report["command"], "smooth")
        self.assertEqual(report["points"], 3000)
        self.assertLessEqual(report["steps"], 6)

    def test_output_options_and_las(self):
        las = self.path("cube.las")
        run_cli("generate", "cube", las, "--points", 2000, "--noise", 0.5)
        _, cloud = self.run_both(las, ".las", ["--colour-by", "kmax", "--attributes", "--paper", "--steps", "4"],
                                 {"colour_by": "kmax", "attributes": True, "paper": True, "steps": 4})
        for name in ("red", "green", "blue", "k1", "feature_class"):
            self.assertIn(name, cloud)

    def test_neighbors_from_and_threads(self):
        source = self.generated("sphere")
        reference = self.generated("sphere", noise=0.1, name="reference.ply")
        report, _ = self.run_both(source, ".xyz", ["--neighbors-from", reference, "--steps", "4", "--threads", "1"],
                                  {"neighbors_from": reference, "steps": 4, "threads": 1})
        self.assertEqual(report["neighbors_from"], reference)
        self.assertEqual(report["threads"], 1)

    def test_budget_that_fits_runs_in_core(self):
        source = self.generated("cube")
        report = pointfair.smooth_file(source, self.path("out.ply"), memory_budget="1G", steps=2)
        self.assertNotIn("out_of_core", report)
        report = pointfair.smooth_file(source, self.path("out2.ply"), memory_budget=1 << 30, steps=2)
        self.assertEqual(report["points"], 3000)

    def test_errors(self):
        source = self.generated("cube")
        with self.assertRaisesRegex(pointfair.IoError, "missing.ply: cannot open"):
            pointfair.smooth_file(self.path("missing.ply"), self.path("out.ply"))
        with self.assertRaisesRegex(ValueError, "unknown option 'colour'"):
            pointfair.smooth_file(source, self.path("out.ply"), colour="kmax")
        with self.assertRaisesRegex(ValueError, "--colour-by must be one of kmax, laplacian, none, got 'red'"):
            pointfair.smooth_file(source, self.path("out.ply"), colour_by="red")
        with self.assertRaisesRegex(ValueError, "memory_budget expects a positive size"):
            pointfair.smooth_file(source, self.path("out.ply"), memory_budget="lots")
        with self.assertRaisesRegex(pointfair.IoError, "output would overwrite the input"):
            pointfair.smooth_file(source, source)

    def test_progress_exception_leaves_no_output(self):
        source = self.generated("cube")
        out = self.path("out.ply")

        def stop(stage, done, total):
            raise RuntimeError("stopped by the test")

        with self.assertRaisesRegex(RuntimeError, "stopped by the test"):
            pointfair.smooth_file(source, out, progress=stop)
        self.assertEqual([n for n in os.listdir(self._folder.name) if n.startswith("out")], [])


# A small budget that tiles a few thousand points; quadric_k 40 keeps the finish's tiles in it.
SMALL_BUDGET = "1M"
OUT_OF_CORE = {"steps": 3, "quadric_k": 40, "threads": 2}
OUT_OF_CORE_CLI = ["--steps", "3", "--quadric-k", "40", "--threads", "2"]


class SmoothFileOutOfCore(Compared):
    def left_in_folder(self):
        return sorted(n for n in os.listdir(self._folder.name) if not n.startswith("raw-"))

    def test_tiled_run_is_the_command_and_the_in_core_run(self):
        source = self.generated("cube", points=4000)
        report, cloud = self.run_both(source, ".ply", ["--memory-budget", SMALL_BUDGET, *OUT_OF_CORE_CLI],
                                      dict(OUT_OF_CORE, memory_budget=SMALL_BUDGET))
        self.assertIs(report["out_of_core"], True)
        self.assertGreater(report["tiles"], 1)
        self.assertEqual(report["points"], 4000)
        self.assertEqual(report["memory_budget_bytes"], 1 << 20)
        for key in ("resumed_from", "peak_accounted_bytes", "largest_tile_with_halo", "tiles_in_flight",
                    "temporal_block", "bytes_read_per_step"):
            self.assertIn(key, report)
        self.assertEqual(report["resumed_from"], 0)
        # The out-of-core run gives the in-core bits (the command's guarantee).
        in_core = pointfair.smooth_file(source, self.path("core.ply"), **OUT_OF_CORE)
        self.assertNotIn("out_of_core", in_core)
        assert_same_bits(self, cloud["xyz"], pointfair.read(self.path("core.ply"))["xyz"])
        # The run's folder beside the output is gone.
        self.assertEqual(self.left_in_folder(), ["cli.ply", "core.ply", "cube-4000-1.ply", "py.ply"])

    def test_container_input_and_output(self):
        source = self.generated("sphere", points=3000)
        container = self.path("in.h5")
        run_cli("import", source, container, "--quiet")
        report, _ = self.run_both(container, ".xyz", OUT_OF_CORE_CLI, OUT_OF_CORE)
        self.assertIs(report["out_of_core"], True)
        self.assertEqual(report["memory_budget_bytes"], 256 << 20)  # the command's default
        # A container output holds the run; its export is the point file's bits.
        progress = []
        report = pointfair.smooth_file(source, self.path("out.h5"), progress=lambda *a: progress.append(a),
                                       **OUT_OF_CORE)
        self.assertIs(report["out_of_core"], True)
        self.assertEqual({stage for stage, _, _ in progress} & {"import", "steps", "finish"},
                         {"import", "steps", "finish"})
        run_cli("export", self.path("out.h5"), self.path("back.xyz"), "--quiet")
        assert_same_bits(self, pointfair.read(self.path("back.xyz"))["xyz"], pointfair.read(self.path("py.xyz"))["xyz"])

    def test_errors_name_the_file_and_leave_nothing(self):
        source = self.generated("cube", points=4000)
        before = self.left_in_folder()
        with self.assertRaisesRegex(pointfair.ParamError, "memory budget of 256 KiB is too small for .*cube-4000-1.ply"):
            pointfair.smooth_file(source, self.path("out.ply"), memory_budget="256K", steps=2)
        with self.assertRaisesRegex(pointfair.ParamError, "memory_budget must be a positive number of bytes"):
            pointfair.smooth_file(source, self.path("out.ply"), memory_budget=0)
        with self.assertRaisesRegex(pointfair.IoError, "missing.ply: cannot open"):
            pointfair.smooth_file(self.path("missing.ply"), self.path("out.ply"), memory_budget=SMALL_BUDGET)
        with self.assertRaisesRegex(pointfair.IoError, "missing.h5"):
            pointfair.smooth_file(self.path("missing.h5"), self.path("out.ply"))
        with self.assertRaisesRegex(pointfair.IoError, r"nowhere/\.out\.ply\.pointfair-run: cannot create"):
            pointfair.smooth_file(source, self.path("nowhere/out.ply"), memory_budget=SMALL_BUDGET)
        self.assertEqual(self.left_in_folder(), before)

    def test_stopped_run_leaves_nothing(self):
        source = self.generated("cube", points=4000)
        before = self.left_in_folder()

        def stop(stage, done, total):
            if stage == "steps" and done >= 1:
                raise RuntimeError("stopped by the test")

        for output in ("out.ply", "out.h5"):
            with self.assertRaisesRegex(RuntimeError, "stopped by the test"):
                pointfair.smooth_file(source, self.path(output), memory_budget=SMALL_BUDGET, progress=stop,
                                      **OUT_OF_CORE)
            self.assertEqual(self.left_in_folder(), before)

        def interrupt(stage, done, total):
            if stage == "steps":
                os.kill(os.getpid(), signal.SIGINT)

        with self.assertRaises(KeyboardInterrupt):
            pointfair.smooth_file(source, self.path("out.ply"), memory_budget=SMALL_BUDGET, progress=interrupt,
                                  **OUT_OF_CORE)
        self.assertEqual(self.left_in_folder(), before)


if __name__ == "__main__":
    unittest.main()
