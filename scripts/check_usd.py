#!/usr/bin/env python3
"""Usage: check_usd.py STAGE.usda POSITIONS.npy [--fps N] [--up-axis Y] [--meters-per-unit 1] [--tolerance 1e-6]

Opens a hair export (`hair run SCENE --usd STAGE.usda --positions POSITIONS.npy`) with Pixar's
USD library and checks it against the positions the simulation wrote: the curves' points at the
first, middle and last time samples equal the positions file's frames to the tolerance (metres
times metersPerUnit), the stage's metadata is what was asked for, the start and end time codes
are the first and last samples, the curve vertex counts add up to the points, and USD's own
validators (UsdValidation, where the installed USD has it) find no error. Prints the
number of curves, points and time samples. Exit status: 0 when everything matches, 1 on a
mismatch (each one printed), 2 when USD or NumPy is missing or a file cannot be read.

The positions file is a float32 array of shape [frames, points, 3]; frame k is the k-th time
sample in time order.
"""

import argparse
import sys


def main():
    parser = argparse.ArgumentParser(description="Check a hair USD export against its positions.")
    parser.add_argument("stage", help="the exported .usda file")
    parser.add_argument("positions", help="the .npy positions file written beside it")
    parser.add_argument("--fps", type=float, help="expected timeCodesPerSecond (not checked if absent)")
    parser.add_argument("--up-axis", default="Y", choices=["Y", "Z"], help="expected upAxis (Y)")
    parser.add_argument("--meters-per-unit", type=float, default=1.0, help="expected metersPerUnit (1)")
    parser.add_argument("--tolerance", type=float, default=1e-6, help="largest position difference in metres (1e-6)")
    args = parser.parse_args()

    try:
        from pxr import Usd, UsdGeom
    except ImportError:
        print("usd-core is not installed: pip install usd-core", file=sys.stderr)
        return 2
    try:
        import numpy as np
    except ImportError:
        print("numpy is not installed: pip install numpy", file=sys.stderr)
        return 2

    stage = Usd.Stage.Open(args.stage)
    if stage is None:
        print(f"{args.stage}: USD could not open it", file=sys.stderr)
        return 2
    try:
        positions = np.load(args.positions, mmap_mode="r")
    except (OSError, ValueError) as e:
        print(f"{args.positions}: {e}", file=sys.stderr)
        return 2

    errors = []

    def expect(what, got, want):
        if got != want:
            errors.append(f"{what}: {got!r}, expected {want!r}")

    # Metadata, authored rather than USD's fallbacks.
    for key in ["upAxis", "metersPerUnit", "timeCodesPerSecond", "startTimeCode", "endTimeCode"]:
        if not stage.HasAuthoredMetadata(key):
            errors.append(f"{args.stage}: layer metadata `{key}` is not written")
    expect("upAxis", UsdGeom.GetStageUpAxis(stage), args.up_axis)
    expect("metersPerUnit", UsdGeom.GetStageMetersPerUnit(stage), args.meters_per_unit)
    if args.fps is not None:
        expect("timeCodesPerSecond", stage.GetTimeCodesPerSecond(), args.fps)

    curves = [UsdGeom.BasisCurves(p) for p in stage.Traverse() if p.IsA(UsdGeom.BasisCurves)]
    if len(curves) != 1:
        errors.append(f"{args.stage}: {len(curves)} BasisCurves prims, expected 1")
        return report(errors)
    curve = curves[0]
    path = curve.GetPath()
    counts = list(curve.GetCurveVertexCountsAttr().Get() or [])
    times = curve.GetPointsAttr().GetTimeSamples()
    total = sum(counts)
    print(f"{path}: {len(counts)} curves, {total} points, {len(times)} time samples "
          f"({curve.GetTypeAttr().Get()}, {curve.GetWrapAttr().Get()})")
    if not times:
        errors.append(f"{path}.points: no time samples")
        return report(errors)
    expect("startTimeCode", stage.GetStartTimeCode(), times[0])
    expect("endTimeCode", stage.GetEndTimeCode(), times[-1])
    if positions.ndim != 3 or positions.shape[2] != 3:
        errors.append(f"{args.positions}: shape {positions.shape}, expected [frames, points, 3]")
        return report(errors)
    expect(f"{args.positions} frames (time samples in {path})", positions.shape[0], len(times))
    expect(f"{args.positions} points per frame (sum of curveVertexCounts)", positions.shape[1], total)

    # The tolerance is in metres; the stage's points are in its units.
    tolerance = args.tolerance / UsdGeom.GetStageMetersPerUnit(stage)
    for k in sorted({0, len(times) // 2, len(times) - 1}):
        t = times[k]
        points = np.asarray(curve.GetPointsAttr().Get(t), dtype=np.float32)
        if points.shape != (total, 3):
            errors.append(f"{path}.points at time {t}: shape {points.shape}, expected ({total}, 3)")
            continue
        if k >= positions.shape[0]:
            continue
        diff = np.abs(points.astype(np.float64) - np.asarray(positions[k], dtype=np.float64))
        worst = float(diff.max()) if diff.size else 0.0
        exact = int(np.count_nonzero(points.view(np.uint32) != np.asarray(positions[k]).view(np.uint32)))
        print(f"  time {t} (frame {k}): largest difference {worst:.3g}, {exact} of {diff.size} values not bit-equal")
        if worst > tolerance:
            i = int(np.argmax(diff.max(axis=1)))
            errors.append(
                f"{path}.points at time {t}: point {i} is {points[i].tolist()} in the stage but "
                f"{np.asarray(positions[k][i]).tolist()} in {args.positions} (difference {worst:.3g})")
    validate(stage, errors)
    return report(errors)


def validate(stage, errors):
    """Runs every validator the installed USD registers: errors fail the check, the rest print."""
    try:
        from pxr import UsdValidation
    except ImportError:
        print("  (this USD has no UsdValidation; its validators were not run)")
        return
    validators = UsdValidation.ValidationRegistry().GetOrLoadAllValidators()
    issues = UsdValidation.ValidationContext(validators).Validate(stage)
    print(f"  USD validators: {len(validators)} run, {len(issues)} issues")
    for issue in issues:
        line = f"{issue.GetName()}: {issue.GetMessage()}"
        if issue.GetType() == UsdValidation.ValidationErrorType.Error:
            errors.append(f"USD validator {line}")
        else:
            print(f"  {issue.GetType()} {line}")


def report(errors):
    for e in errors:
        print(f"MISMATCH {e}", file=sys.stderr)
    if errors:
        print(f"{len(errors)} mismatch(es)", file=sys.stderr)
        return 1
    print("ok")
    return 0


if __name__ == "__main__":
    sys.exit(main())
