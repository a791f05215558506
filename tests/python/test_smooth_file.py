"""pointfair.smooth_file against `pointfair smooth ... --json`: the same file and summary."""
import json
import os
import unittest

import numpy as np

import pointfair
from support import Folder, assert_same_bits, run_cli

# Keys whose values are times or rates: present in both, values differ run to run.
TIMED = {"seconds", "point_steps_per_second"}


def same_keys(a, b):
    if isinstance(a, dict) and isinstance(b, dict):
        return sorted(a) == sorted(b) and all(same_keys(a[k], b[k]) for k in a)
    return not isinstance(a, dict) and not isinstance(b, dict)


class SmoothFile(Folder):
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

    def test_out_of_core_is_refused(self):
        source = self.generated("cube")
        with self.assertRaisesRegex(NotImplementedError, "3000 points under a memory budget of 1048576 bytes"):
            pointfair.smooth_file(source, self.path("out.ply"), memory_budget="1M")
        with self.assertRaisesRegex(NotImplementedError, r"an HDF5 container \(.*out.h5\)"):
            pointfair.smooth_file(source, self.path("out.h5"))

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

if __name__ == "__main__":
    unittest.main()
