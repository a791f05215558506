"""pointfair.read and pointfair.write: every format, every attribute type, every error."""
import json
import os
import unittest

import numpy as np

import pointfair
from support import Folder, assert_same_bits, run_cli

N = 50


def columns():
    rng = np.random.default_rng(5)
    return {
        "xyz": rng.uniform(-10, 10, size=(N, 3)),
        "a_uint8": rng.integers(0, 256, N).astype(np.uint8),
        "a_uint16": rng.integers(0, 65536, N).astype(np.uint16),
        "a_uint32": rng.integers(0, 2**32, N, dtype=np.uint64).astype(np.uint32),
        "a_int8": rng.integers(-128, 128, N).astype(np.int8),
        "a_int16": rng.integers(-32768, 32768, N).astype(np.int16),
        "a_int32": rng.integers(-2**31, 2**31, N).astype(np.int32),
        "a_float32": rng.normal(size=N).astype(np.float32),
        "a_float64": rng.normal(size=N),
    }


class RoundTrip(Folder):
    def test_ply_keeps_every_type(self):
        cloud = columns()
        for encoding in ("binary", "binary-be", "ascii"):
            path = self.path(f"cloud-{encoding}.ply")
            pointfair.write(path, cloud, encoding=encoding)
            back = pointfair.read(path)
            self.assertEqual(list(back), list(cloud))
            for name, values in cloud.items():
                assert_same_bits(self, back[name], values)
        with open(self.path("cloud-ascii.ply"), "rb") as f:
            self.assertIn(b"format ascii", f.read(200))

    def test_text_keeps_values(self):
        cloud = columns()
        for extension in (".xyz", ".csv", ".txt", ".asc"):
            path = self.path("cloud" + extension)
            pointfair.write(path, cloud)
            back = pointfair.read(path)
            self.assertEqual(list(back), list(cloud))
            np.testing.assert_array_equal(back["xyz"], cloud["xyz"])
            for name, values in cloud.items():
                np.testing.assert_array_equal(back[name].astype(np.float64), values.astype(np.float64),
                                              err_msg=f"{extension} {name}")

    def test_las_keeps_fields_and_extra_bytes(self):
        cloud = columns()
        cloud["intensity"] = np.arange(N, dtype=np.uint16) * 100
        cloud["classification"] = (np.arange(N) % 7).astype(np.uint8)
        cloud["red"] = np.arange(N, dtype=np.uint16) * 1000
        cloud["green"] = np.full(N, 7, dtype=np.uint16)
        cloud["blue"] = np.full(N, 65535, dtype=np.uint16)
        path = self.path("cloud.las")
        pointfair.write(path, cloud)
        back = pointfair.read(path)
        # LAS stores positions on an integer grid: at most half its step off.
        np.testing.assert_allclose(back["xyz"], cloud["xyz"], rtol=0, atol=1e-3)
        for name in ("intensity", "classification", "red", "green", "blue", "a_uint8", "a_uint16",
                     "a_int16", "a_int32", "a_float32", "a_float64"):
            assert_same_bits(self, back[name], cloud[name])
        # The command reads what write() wrote.
        info = json.loads(run_cli("info", path, "--json"))
        self.assertEqual(info["points"], N)
        self.assertEqual(info["attributes"]["a_float32"]["type"], "float")

    def test_float32_positions_and_narrowed_integers(self):
        path = self.path("small.ply")
        xyz = np.arange(9, dtype=np.float32).reshape(3, 3)
        pointfair.write(path, {"xyz": xyz, "count": np.array([1, 2, 3]), "flag": np.array([True, False, True])})
        back = pointfair.read(path)
        assert_same_bits(self, back["xyz"], xyz.astype(np.float64))
        self.assertEqual(back["count"].dtype, np.int32)
        self.assertEqual(back["flag"].dtype, np.uint8)
        np.testing.assert_array_equal(back["flag"], [1, 0, 1])
        with open(path, "rb") as f:
            self.assertIn(b"property float x", f.read(300))

    def test_reader_notes_are_warnings(self):
        path = self.path("faces.ply")
        with open(path, "w") as f:
            f.write("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                    "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                    "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
        with self.assertWarnsRegex(RuntimeWarning, "face"):
            cloud = pointfair.read(path)
        self.assertEqual(cloud["xyz"].shape, (3, 3))

    def test_reads_what_the_command_writes(self):
        path = self.path("generated.ply")
        run_cli("generate", "sphere", path, "--points", 100)
        cloud = pointfair.read(path)
        self.assertEqual(cloud["xyz"].shape, (100, 3))
        self.assertEqual(sorted(cloud), ["nx", "ny", "nz", "xyz"])
        np.testing.assert_allclose(np.linalg.norm(cloud["xyz"], axis=1), 1.0, atol=1e-6)


class Errors(Folder):
    def test_missing_file(self):
        path = self.path("nothing.ply")
        with self.assertRaisesRegex(OSError, "nothing.ply: cannot open") as caught:
            pointfair.read(path)
        self.assertIsInstance(caught.exception, pointfair.IoError)

    def test_bad_file(self):
        path = self.path("bad.ply")
        with open(path, "w") as f:
            f.write("ply\nformat binary_little_endian 1.0\nelement vertex 10\nproperty float x\nend_header\n")
        with self.assertRaisesRegex(pointfair.IoError, "bad.ply: "):
            pointfair.read(path)
        text = self.path("bad.xyz")
        with open(text, "w") as f:
            f.write("1 2 3\n4 five 6\n")
        with self.assertRaisesRegex(pointfair.IoError, "bad.xyz"):
            pointfair.read(text)

    def test_unknown_extension(self):
        with self.assertRaisesRegex(pointfair.IoError, "unknown file extension '.foo'"):
            pointfair.read(self.path("x.foo"))
        with self.assertRaisesRegex(pointfair.IoError, "unknown file extension '.foo'"):
            pointfair.write(self.path("x.foo"), {"xyz": np.zeros((2, 3))})

    def test_unwritable_folder(self):
        with self.assertRaisesRegex(pointfair.IoError, "missing-folder"):
            pointfair.write(self.path("missing-folder/x.ply"), {"xyz": np.zeros((2, 3))})

    def test_bad_clouds(self):
        path = self.path("x.ply")
        xyz = np.zeros((4, 3))
        cases = [
            ({"a": np.zeros(4)}, "has no 'xyz' entry"),
            ({"xyz": xyz.astype(np.int32)}, "xyz: expected dtype float64, got int32"),
            ({"xyz": xyz[:, :2].copy()}, r"xyz: expected an array of shape \(N, 3\)"),
            ({"xyz": xyz, "a": np.zeros(5)}, r"a: expected an array of shape \(4,\)"),
            ({"xyz": xyz, "a": np.zeros((4, 3))}, r"a: expected an array of shape \(4,\)"),
            ({"xyz": xyz, "a": np.zeros(4, dtype=np.complex128)}, "a: dtype complex128 cannot be stored"),
            ({"xyz": xyz, "a": np.array(["p", "q", "r", "s"])}, "a: dtype <U1 cannot be stored"),
            ({"xyz": xyz, "a": np.full(4, 2**40)}, "a: int64 values beyond int32"),
            ({"xyz": xyz, "a": np.zeros(4, dtype=">i4")}, "a: dtype >i4 is not in the machine's byte order"),
        ]
        for cloud, pattern in cases:
            with self.subTest(pattern=pattern):
                with self.assertRaisesRegex(ValueError, pattern):
                    pointfair.write(path, cloud)
        with self.assertRaisesRegex(ValueError, "encoding must be one of binary, binary-be, ascii"):
            pointfair.write(path, {"xyz": xyz}, encoding="utf8")
        self.assertFalse(os.path.exists(path))


if __name__ == "__main__":
    unittest.main()
