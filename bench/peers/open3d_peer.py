#!/usr/bin/python3
"""Open3D peer for the FeatureExtract benchmark suite.

Finds all regions of a target mesh similar to a reference feature mesh using
the pipeline recommended by Open3D's "Global registration" tutorial:

  uniform surface sampling (seeded, counts proportional to area)
  -> voxel downsampling (voxel = reference bounding-box diagonal / 30)
  -> normals (KDTreeSearchParamHybrid radius 2*voxel, max_nn 30)
  -> FPFH (radius 5*voxel, max_nn 100)
  -> registration_ransac_based_on_feature_matching
  -> ICP refinement (point-to-plane; point-to-point with scaling if --scaling)

Several instances are found greedily: after each RANSAC+ICP attempt the target
points close to the aligned reference are removed and the search is repeated.
An attempt is accepted when its fitness (fraction of reference points having a
remaining target point within the ICP distance) is >= the acceptance
threshold (--accept-fitness, default 0.95) and, with --scaling, its scale
lies in the range admitted by the edge-length checker ([0.5, 2]).  The search
stops after --max-instances accepted instances, after 2 consecutive rejected
attempts, or when too few target points remain.

Tuning (one case only: rib_reference vs ribs_bosses, seeds 0-3): identical
ribs fit 1.00, the reference laid against plate edges/corners fits up to 0.885,
a wider (13 mm) rib fits ~0.7.  Fitness does not separate that wider rib from
plate-edge false matches, so the default threshold 0.95 was chosen to reject
the latter; the brief's suggestion 0.6 can be restored with --accept-fitness.

Usage:
  /usr/bin/python3 bench/peers/open3d_peer.py --reference REF.stl \
      --target TGT.stl --output OUT.json [--seed N] [--scaling] \
      [--max-instances K] [--accept-fitness F] [--threads T]

Exit codes: 0 ok, 2 usage error, 3 unreadable/empty input.

Determinism: sampling and RANSAC draw from Open3D's global random engine,
seeded by --seed.  Open3D 0.16's RANSAC loop is OpenMP-parallel and the
threads share that engine, so with more than one thread the order of draws
(and hence the result) can vary between runs.  This script therefore sets
OMP_NUM_THREADS from --threads (default 1) *before* importing open3d; with one
thread the output is reproducible for a given seed.
"""

import argparse
import json
import os
import sys
import time


# ---------------------------------------------------------------- parameters
VOXEL_PER_DIAG = 30.0          # voxel = L / 30
SAMPLES_PER_VOXEL_AREA = 6.0   # uniform samples per voxel^2 of surface
NORMAL_RADIUS = 2.0            # * voxel
NORMAL_MAX_NN = 30
FPFH_RADIUS = 5.0              # * voxel
FPFH_MAX_NN = 100
RANSAC_DIST = 1.5              # * voxel
RANSAC_N = 3
MUTUAL_FILTER = False          # repeated instances: a mutual filter would
                               # discard most true matches
EDGE_LENGTH_SIM = 0.9          # 0.5 with --scaling (0.9 forbids scale > 1.11)
RANSAC_MAX_ITER = 100000
RANSAC_CONFIDENCE = 0.999
ICP_DIST = 1.0                 # * voxel
ICP_MAX_ITER = 50
ACCEPT_FITNESS = 0.95            # tuned on ribs_bosses only (see report)
REMOVE_RADIUS = 1.5            # * voxel: target points removed per attempt
MAX_CONSECUTIVE_FAILURES = 2


def parse_args(argv):
    p = argparse.ArgumentParser(description="Open3D FPFH+RANSAC+ICP peer")
    p.add_argument("--reference", required=True)
    p.add_argument("--target", required=True)
    p.add_argument("--output", required=True)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--scaling", action="store_true")
    p.add_argument("--max-instances", type=int, default=12)
    p.add_argument("--accept-fitness", type=float, default=ACCEPT_FITNESS)
    p.add_argument("--threads", type=int, default=1,
                   help="OpenMP threads for Open3D (1 = deterministic)")
    a = p.parse_args(argv)  # exits with status 2 on usage errors
    if a.max_instances < 1 or a.threads < 1:
        p.error("--max-instances and --threads must be >= 1")
    return a


ARGS = parse_args(sys.argv[1:])
os.environ["OMP_NUM_THREADS"] = str(ARGS.threads)

import numpy as np  # noqa: E402
import open3d as o3d  # noqa: E402
from scipy.spatial import cKDTree  # noqa: E402

reg = o3d.pipelines.registration


def fail_input(path, why):
    sys.stderr.write("open3d_peer: cannot use input file %s: %s\n" % (path, why))
    sys.exit(3)


def read_mesh(path):
    if not os.path.isfile(path):
        fail_input(path, "no such file")
    try:
        mesh = o3d.io.read_triangle_mesh(path)
    except Exception as e:  # pragma: no cover
        fail_input(path, str(e))
    if len(mesh.triangles) == 0 or len(mesh.vertices) == 0:
        fail_input(path, "unreadable or empty mesh")
    area = mesh.get_surface_area()
    if not np.isfinite(area) or area <= 0.0:
        fail_input(path, "mesh has zero surface area")
    mesh.compute_triangle_normals()
    return mesh, area


def prepare(mesh, area, voxel):
    """Sample, downsample, estimate normals and FPFH."""
    n = int(max(1000, round(area * SAMPLES_PER_VOXEL_AREA / voxel ** 2)))
    # use_triangle_normal: the (outward, CAD-oriented) face normals are only
    # used to orient the PCA normals estimated below consistently.
    pcd = mesh.sample_points_uniformly(number_of_points=n,
                                       use_triangle_normal=True)
    pcd = pcd.voxel_down_sample(voxel)
    # Open3D keeps the orientation of existing normals when re-estimating.
    pcd.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(
        radius=NORMAL_RADIUS * voxel, max_nn=NORMAL_MAX_NN))
    fpfh = reg.compute_fpfh_feature(pcd, o3d.geometry.KDTreeSearchParamHybrid(
        radius=FPFH_RADIUS * voxel, max_nn=FPFH_MAX_NN))
    return pcd, fpfh, n


def subset_feature(feat_data, idx):
    f = reg.Feature()
    f.data = np.ascontiguousarray(feat_data[:, idx])
    return f


def evaluate(src_pts, tgt_tree, T, dist):
    """Fitness / rmse of transformed source points against a KD-tree."""
    pts = src_pts @ T[:3, :3].T + T[:3, 3]
    d, _ = tgt_tree.query(pts, k=1)
    inl = d <= dist
    fit = float(inl.mean())
    rmse = float(np.sqrt(np.mean(d[inl] ** 2))) if inl.any() else 0.0
    return fit, rmse, pts


def main():
    t0 = time.perf_counter()
    o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)
    o3d.utility.random.seed(ARGS.seed)
    np.random.seed(ARGS.seed)

    ref_mesh, ref_area = read_mesh(ARGS.reference)
    tgt_mesh, tgt_area = read_mesh(ARGS.target)
    t_read = time.perf_counter()

    L = float(np.linalg.norm(
        ref_mesh.get_axis_aligned_bounding_box().get_extent()))
    voxel = L / VOXEL_PER_DIAG
    src, src_fpfh, n_ref = prepare(ref_mesh, ref_area, voxel)
    tgt, tgt_fpfh, n_tgt = prepare(tgt_mesh, tgt_area, voxel)
    t_feat = time.perf_counter()

    src_pts = np.asarray(src.points)
    tgt_pts_all = np.asarray(tgt.points)
    tgt_normals_all = np.asarray(tgt.normals)
    tgt_feat_all = np.asarray(tgt_fpfh.data)
    alive = np.ones(len(tgt_pts_all), dtype=bool)

    edge_sim = 0.5 if ARGS.scaling else EDGE_LENGTH_SIM
    checkers = [reg.CorrespondenceCheckerBasedOnEdgeLength(edge_sim),
                reg.CorrespondenceCheckerBasedOnDistance(RANSAC_DIST * voxel)]
    est_ransac = reg.TransformationEstimationPointToPoint(ARGS.scaling)
    if ARGS.scaling:
        est_icp = reg.TransformationEstimationPointToPoint(True)
    else:
        est_icp = reg.TransformationEstimationPointToPlane()
    criteria = reg.RANSACConvergenceCriteria(RANSAC_MAX_ITER,
                                             RANSAC_CONFIDENCE)

    matches = []
    attempts = []
    failures = 0
    while len(matches) < ARGS.max_instances and failures < MAX_CONSECUTIVE_FAILURES:
        idx = np.flatnonzero(alive)
        if len(idx) < max(3 * RANSAC_N, ARGS.accept_fitness * len(src_pts)):
            break
        cur = o3d.geometry.PointCloud()
        cur.points = o3d.utility.Vector3dVector(tgt_pts_all[idx])
        cur.normals = o3d.utility.Vector3dVector(tgt_normals_all[idx])
        cur_feat = subset_feature(tgt_feat_all, idx)

        ransac = reg.registration_ransac_based_on_feature_matching(
            src, cur, src_fpfh, cur_feat, MUTUAL_FILTER, RANSAC_DIST * voxel,
            est_ransac, RANSAC_N, checkers, criteria)
        T = np.asarray(ransac.transformation)
        if ransac.fitness > 0.0:
            icp = reg.registration_icp(
                src, cur, ICP_DIST * voxel, T, est_icp,
                reg.ICPConvergenceCriteria(max_iteration=ICP_MAX_ITER))
            T = np.asarray(icp.transformation)

        tree = cKDTree(tgt_pts_all[idx])
        fit, rmse, aligned = evaluate(src_pts, tree, T, ICP_DIST * voxel)
        center = aligned.mean(axis=0)
        scale = float(np.cbrt(max(np.linalg.det(T[:3, :3]), 0.0)))
        # A similarity outside the range the edge-length checker admits
        # (e.g. a collapsed scale ~0) is degenerate: never accept it.
        scale_ok = edge_sim <= scale <= 1.0 / edge_sim
        accepted = fit >= ARGS.accept_fitness and scale_ok
        attempts.append({"ransac_fitness": float(ransac.fitness),
                         "fitness": fit, "accepted": bool(accepted),
                         "transform": [[float(v) for v in row] for row in T],
                         "center": [float(c) for c in center],
                         "scale": scale})

        # Remove remaining target points near the aligned reference (also for
        # rejected attempts, so the next search explores elsewhere).
        dn, _ = cKDTree(aligned).query(tgt_pts_all[idx], k=1,
                                       distance_upper_bound=REMOVE_RADIUS * voxel)
        near = idx[np.isfinite(dn)]
        alive[near] = False
        removed = len(near)

        if accepted:
            failures = 0
            matches.append({"transform": [[float(v) for v in row] for row in T],
                            "fitness": fit, "rmse": rmse,
                            "center": [float(c) for c in center]})
        else:
            failures += 1
        if removed == 0 and not accepted:
            break  # nothing changes: the next attempt would be identical
    t_end = time.perf_counter()

    out = {
        "method": "open3d-fpfh-ransac-icp" + ("-scaling" if ARGS.scaling else ""),
        "matches": matches,
        "timings": {"read": t_read - t0, "features": t_feat - t_read,
                    "search": t_end - t_feat, "total": t_end - t0},
        "parameters": {
            "open3d_version": o3d.__version__,
            "seed": ARGS.seed, "threads": ARGS.threads,
            "scaling": ARGS.scaling, "max_instances": ARGS.max_instances,
            "reference_diagonal": L, "voxel": voxel,
            "voxel_per_diagonal": VOXEL_PER_DIAG,
            "sampling": "sample_points_uniformly",
            "samples_per_voxel_area": SAMPLES_PER_VOXEL_AREA,
            "reference_samples": n_ref, "target_samples": n_tgt,
            "reference_points": len(src_pts),
            "target_points": len(tgt_pts_all),
            "normals": "PCA, hybrid radius %g*voxel max_nn %d, oriented by "
                       "mesh face normals" % (NORMAL_RADIUS, NORMAL_MAX_NN),
            "fpfh_radius": FPFH_RADIUS * voxel, "fpfh_max_nn": FPFH_MAX_NN,
            "mutual_filter": MUTUAL_FILTER,
            "ransac_max_correspondence_distance": RANSAC_DIST * voxel,
            "ransac_n": RANSAC_N,
            "checker_edge_length": edge_sim,
            "checker_distance": RANSAC_DIST * voxel,
            "ransac_max_iteration": RANSAC_MAX_ITER,
            "ransac_confidence": RANSAC_CONFIDENCE,
            "icp": ("point-to-point with scaling" if ARGS.scaling
                    else "point-to-plane"),
            "icp_max_distance": ICP_DIST * voxel,
            "icp_max_iteration": ICP_MAX_ITER,
            "accept_fitness": ARGS.accept_fitness,
            "accept_scale_range": [edge_sim, 1.0 / edge_sim],
            "fitness_distance": ICP_DIST * voxel,
            "remove_radius": REMOVE_RADIUS * voxel,
            "max_consecutive_failures": MAX_CONSECUTIVE_FAILURES,
        },
        "attempts": attempts,
    }
    tmp = ARGS.output + ".tmp"
    with open(tmp, "w") as f:
        json.dump(out, f, indent=1)
        f.write("\n")
    os.replace(tmp, ARGS.output)
    return 0


if __name__ == "__main__":
    sys.exit(main())
