"""Runs the example of docs/python.md (its first ```python block, as the page shows it) on a
small LAS file written by `pointfair generate`, and checks what it wrote.

usage: run_docs_example.py docs/python.md   (PYTHONPATH and POINTFAIR_EXE as for the tests)"""
import os
import re
import subprocess
import sys
import tempfile

import numpy as np

import pointfair


def example(page):
    with open(page, encoding="utf-8") as f:
        text = f.read()
    blocks = re.findall(r"^```python\n(.*?)^```", text, flags=re.S | re.M)
    if not blocks:
        sys.exit(f"{page}: no ```python block")
    return blocks[0]


def main():
    code = example(sys.argv[1])
    exe = os.environ.get("POINTFAIR_EXE", "pointfair")
    with tempfile.TemporaryDirectory(prefix="pointfair-docs-") as folder:
        source, target = os.path.join(folder, "cube.las"), os.path.join(folder, "smooth.las")
        script = os.path.join(folder, "example.py")
        with open(script, "w", encoding="utf-8") as f:
            f.write(code)
        subprocess.run([exe, "generate", "cube", source, "--points", "4000", "--noise", "0.5"],
                       check=True, capture_output=True)
        subprocess.run([sys.executable, script, source, target], check=True)

        before, after = pointfair.read(source), pointfair.read(target)
        n = len(before["xyz"])
        problems = []
        if after["xyz"].shape != (n, 3):
            problems.append(f"{len(after['xyz'])} points written, {n} read")
        for name in before:  # every field of the input is still there
            if name not in after:
                problems.append(f"field {name} lost")
        for name in ("intensity", "classification", "gps_time"):
            if name in before and not np.array_equal(before[name], after[name]):
                problems.append(f"field {name} changed")
        for name in ("red", "green", "blue"):
            if after.get(name) is None or after[name].dtype != np.uint16:
                problems.append(f"{name}: missing or not uint16")
        if after.get("k1") is None or after["k1"].dtype != np.float32:
            problems.append("k1: missing or not float32")
        else:
            # Red follows k1: the cube's edges and corners (convex, k1 > 0) are the reddest.
            red = after["red"].astype(np.float64)
            if not red.max() > red.min() or np.corrcoef(red, after["k1"])[0, 1] < 0.5:
                problems.append("red does not follow k1")
        moved = np.linalg.norm(after["xyz"] - before["xyz"], axis=1)
        if not 0 < np.median(moved) < 0.05:
            problems.append(f"median move {np.median(moved):.3g}: not smoothed")
        if problems:
            sys.exit("docs/python.md example: " + "; ".join(problems))
        print(f"docs/python.md example: {n} points smoothed and coloured by k1")


if __name__ == "__main__":
    main()
