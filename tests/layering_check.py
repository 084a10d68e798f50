#!/usr/bin/env python3
"""Checks core's layout: one folder per pipeline stage, includes that only point down.

The stages, lowest first (docs/development.md, "Layout"):

  common   value types and helpers every stage uses (geometry, the board, stats)
  camera   detection, PnP, camera model, tags        } peers: neither includes the other
  lidar    range image, segmentation, PCA, M2DP      }
  session  pairing, observations, motion, scenery
  solve    grid search, box costs, optimisers
  verdict  every check of a solved session, reason codes
  engine   the pipeline's steps in order

A file of a stage may include its own stage and those below it, never one above nor its peer.
Core includes nothing of drivers/, agent/ or tools/. Every source and header sits in a stage's
folder, and no folder holds more than MAX_FILES sources (or headers): a longer list no longer
tells a newcomer what is in it.

Usage: layering_check.py SOURCE_DIR. Exit 1 with each offending line named.
"""
import pathlib
import re
import sys

LEVELS = {"common": 0, "camera": 1, "lidar": 1, "session": 2, "solve": 3, "verdict": 4,
          "engine": 5}
MAX_FILES = 12
INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"')


def included_stage(path):
    """The stage a quoted include names, None for a header outside core's stages."""
    for prefix in ("calibd/core/", ""):
        if path.startswith(prefix):
            head = path[len(prefix):].split("/")[0]
            if head in LEVELS and "/" in path[len(prefix):]:
                return head
    return None


def main():
    root = pathlib.Path(sys.argv[1]) / "core"
    errors = []
    for top in (root / "include" / "calibd" / "core", root / "src"):
        for f in sorted(top.iterdir()):
            if f.is_file():
                errors.append(f"{f.relative_to(root.parent)}: not in a stage's folder "
                              f"({', '.join(LEVELS)})")
            elif f.name not in LEVELS:
                errors.append(f"{f.relative_to(root.parent)}: not a stage ({', '.join(LEVELS)})")
        for stage in LEVELS:
            folder = top / stage
            if not folder.is_dir():
                continue
            for suffix in (".cpp", ".hpp"):
                files = sorted(folder.glob("*" + suffix))
                if len(files) > MAX_FILES:
                    errors.append(f"{folder.relative_to(root.parent)}: {len(files)} {suffix} files,"
                                  f" more than {MAX_FILES}: split the stage into sub-steps")
            for f in sorted(folder.rglob("*")):
                if f.suffix not in (".cpp", ".hpp"):
                    continue
                for n, line in enumerate(f.read_text().splitlines(), 1):
                    m = INCLUDE.match(line)
                    if not m:
                        continue
                    name = m.group(1)
                    where = f"{f.relative_to(root.parent)}:{n}: {line.strip()}"
                    if re.match(r"calibd/(drivers|agent|tools)/", name):
                        errors.append(f"{where}: core includes {name.split('/')[1]}")
                        continue
                    other = included_stage(name)
                    if other is None or other == stage:
                        continue
                    if LEVELS[other] > LEVELS[stage]:
                        errors.append(f"{where}: {stage} includes {other}, a later stage")
                    elif LEVELS[other] == LEVELS[stage]:
                        errors.append(f"{where}: {stage} includes its peer {other}")
    for e in errors:
        print(e)
    if errors:
        print(f"layering_check: {len(errors)} problem(s)")
        return 1
    print("layering_check: core's stages include only downwards")
    return 0


if __name__ == "__main__":
    sys.exit(main())
