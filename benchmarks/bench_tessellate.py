"""The part as triangles (`checker.geometry.tessellate.part_triangles` at `check.part_deviation`)
on the realdata STEP/IGES parts: time (best of 3, the cache cleared between runs), triangles,
the measured deviation and how much of the faces' kept (u, v) area the triangles cover.
Run: `python -m benchmarks.bench_tessellate [NAME ...]` (default: the turbine, the IGES blade
and the hammer), when ../shared is present."""

from __future__ import annotations

import sys
from pathlib import Path

from benchmarks.timing import best_of
from checker.config import load_config
from checker.geometry import load_part, tessellate

REALDATA = Path(__file__).resolve().parents[1].parent / "shared" / "realdata" / "occt-cad-nurbs"
DEFAULT = ("ec_turbine-A.stp", "PRO20359-L1.igs", "hammer.iges")


def covered(part, tris) -> float:
    """The smallest share of a face's kept (u, v) area its triangles cover (1 when whole); nan
    for sources without `trim_cells` (an older checkout measured for comparison)."""
    import shapely

    try:
        from checker.geometry.trim_cells import kept_region
    except ImportError:
        return float("nan")

    worst = 1.0
    for s in part.surfaces:
        t = tris.triangles[tris.surface == s.id]
        area = kept_region(s).area
        if area > 0:
            worst = min(worst, float(shapely.area(shapely.polygons(tris.uv[t])).sum()) / area)
    return worst


def main(names: list[str]) -> None:
    cfg = load_config(None)
    print("part | faces | triangles | deviation (mm) | least face covered | best s | median s")
    for name in names or DEFAULT:
        path = REALDATA / name
        if not path.exists():
            print(f"{name}: not found beside the repository (../shared)")
            continue
        part = load_part(path, geometry=cfg.geometry)

        def run(part=part):
            tessellate._CACHE.clear()
            return tessellate.part_triangles(part, cfg.check.part_deviation, cfg.geometry)

        t = best_of(run, 3)
        tris = run()
        print(f"{name} | {len(part.surfaces)} | {len(tris.triangles):,} | {tris.typical:.4f} | "
              f"{covered(part, tris):.6f} | {t.wall:.2f} | {t.median:.2f}")


if __name__ == "__main__":
    main(sys.argv[1:])
