"""Python bindings (issue 3): numpy in and out, errors, progress, cancel, GIL release, target reuse.
Run by ctest with PYTHONPATH=<build>/python and FE_MODELS=<build>/models (see tests/CMakeLists.txt)."""
import os
import threading
import time

import numpy as np
import pytest

import featureextract as fx

MODELS = os.environ.get("FE_MODELS", "build/models")


@pytest.fixture(scope="module")
def ref():
    return fx.read_shape(os.path.join(MODELS, "rib_reference.step"))


@pytest.fixture(scope="module")
def tgt(ref):
    return fx.read_target(os.path.join(MODELS, "ribs_bosses.step"), ref)


def test_params_defaults_docs_and_validation():
    p = fx.Params()
    assert p.seed == 1 and p.shot_radii == 3
    assert "default" in fx.Params.scale_max.__doc__
    names = [row["name"] for row in fx.param_table()]
    assert "pair_distance" in names and len(names) == len(set(names))
    groups = [row["group"] for row in fx.param_table()]
    assert groups[0] == "1. Sampling" and groups[-1] == "Run"
    assert [g for i, g in enumerate(groups) if i == 0 or groups[i - 1] != g] == sorted(set(groups), key=groups.index), \
        "each step's parameters are listed together"
    q = fx.make_params(seed=7, scale_max=2.0)
    assert (q.seed, q.scale_max) == (7, 2.0)
    with pytest.raises(ValueError):
        fx.make_params(no_such_parameter=1)
    with pytest.raises(ValueError):
        p.si_band = 0.9  # out of range
    assert fx.Params.from_json(q.to_json()).seed == 7


def test_mesh_from_arrays_is_validated():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], dtype=float)
    t = np.array([[0, 1, 2], [1, 3, 2]])
    m = fx.Mesh(v, t, np.array([1, 2]), name="quad")
    assert m.triangles.shape == (2, 3) and m.num_faces == 2 and m.face_ids.tolist() == [1, 2]
    with pytest.raises(fx.InputError, match="quad: .*non-finite"):
        fx.Mesh(np.array([[0, 0, 0], [np.nan, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]]), name="quad")
    with pytest.raises(fx.InputError, match="missing vertex"):
        fx.Mesh(v, np.array([[0, 1, 9]]), name="quad")
    with pytest.raises(fx.InputError, match="face_ids"):
        fx.Mesh(v, t, np.array([1]), name="quad")
    with pytest.raises(fx.InputError, match="quad: negative face id"):
        fx.Mesh(v, t, np.array([1, -2]), name="quad")
    with pytest.raises(fx.InputError, match="quad: face id 2000000000 exceeds"):
        fx.Mesh(v, t, np.array([1, 2_000_000_000]), name="quad")


@pytest.mark.parametrize("rel,absolute", [(float("nan"), 0.0), (0.0, 0.0), (-1.0, 0.0), (0.002, float("inf")),
                                          (0.002, float("nan"))])
def test_bad_deflections_are_refused(rel, absolute):
    with pytest.raises(fx.InputError, match="rib_reference.step: tessellation deflections must be finite"):
        fx.read_shape(os.path.join(MODELS, "rib_reference.step"), relative_deflection=rel, absolute_deflection=absolute)


def test_integer_parameters_out_of_range_are_refused():
    for name, value in [("threads", 4294967297), ("seed", 1e30), ("max_dense_points", 1e30)]:
        with pytest.raises(ValueError, match=f"{name} is too large"):
            fx.Params.from_json('{"%s": %r}' % (name, value))


def test_importing_the_package_makes_waiting_threads_sleep():
    # OpenMP's spinning waits slow searches down when the machine is busy; the package asks for the
    # passive policy before the core (and libgomp) is loaded, and keeps a policy the caller chose
    import subprocess
    import sys
    code = "import os, featureextract; print(os.environ.get('OMP_WAIT_POLICY'))"
    env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout
    assert out.strip() == "PASSIVE"
    out = subprocess.run([sys.executable, "-c", code], env=dict(env, OMP_WAIT_POLICY="ACTIVE"), capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "ACTIVE"


def test_result_does_not_depend_on_thread_count(ref, tgt):
    one = fx.extract(ref, tgt, fx.make_params(seed=3, threads=1))
    two = fx.extract(ref, tgt, fx.make_params(seed=3, threads=2))
    assert len(one.matches) == len(two.matches) == 5
    for a, b in zip(one.matches, two.matches):
        assert np.array_equal(a.transform, b.transform) and list(a.faces) == list(b.faces)


def test_bad_file_raises_input_error_naming_it(tmp_path):
    p = tmp_path / "junk.stl"
    p.write_bytes(b"\x01\x02 garbage")
    with pytest.raises(fx.InputError, match=str(p)):
        fx.read_shape(str(p))
    with pytest.raises(ValueError):  # InputError is a ValueError
        fx.read_shape(str(tmp_path / "missing.step"))


BAD = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "..", "shared", "data", "bad-input")


@pytest.mark.parametrize("name", ["step_unknown_entity_FOO.step", "step_dangling_ref.step", "brep_segv.brep",
                                  "brep_truncated_line438_hang.brep", "stl_bin_one_coord_1e12.stl"])
def test_files_that_crash_the_cad_reader_raise_input_error(name):
    """These killed the interpreter (SIGSEGV in OpenCASCADE) or hung: inside FreeCAD, data loss."""
    path = os.path.join(BAD, name)
    t0 = time.monotonic()
    with pytest.raises(fx.InputError, match=name):
        fx.read_shape(path)
    assert time.monotonic() - t0 < 60  # a hang guard (the reading bound is 20 s + 10 s per MB), not a speed goal
    assert fx.read_shape(os.path.join(BAD, "small_reference.stl")).triangles.shape[0] > 0  # still alive and working


def test_a_hanging_cad_file_is_stopped_at_the_time_limit():
    # the caller's own limit: a TimeLimitError (as a run's time_limit); without one, the default bound
    # (20 s + 10 s/MB) takes the file for a bad one: InputError
    t0 = time.monotonic()
    with pytest.raises(fx.TimeLimitError, match="time limit"):
        fx.read_shape(os.path.join(BAD, "brep_edge_token_1e.brep"), time_limit=2)
    assert time.monotonic() - t0 < 30


@pytest.mark.parametrize("values", [{"seed": -1}, {"threads": -5}, {"accept_error": float("nan")}, {"accept_error": object()},
                                    {"accept_error": "x"}, {"no_such_parameter": 1}, {"time_limit": -1}])
def test_bad_parameters_raise_input_error(values):
    """Bad input of any kind raises fx.InputError naming what is wrong (issue 10)."""
    with pytest.raises(fx.InputError, match=next(iter(values)) if "no_such" not in next(iter(values)) else "unknown"):
        fx.make_params(**values)
    with pytest.raises(fx.InputError):
        fx.Params.from_json("{")


def test_time_limit_raises_timeout(ref, tgt):
    with pytest.raises(fx.TimeLimitError, match="time limit"):
        fx.extract(ref, tgt, fx.make_params(time_limit=0.2))
    assert issubclass(fx.TimeLimitError, TimeoutError)


def test_extract_returns_numpy_results(ref, tgt):
    r = fx.extract(ref, tgt, seed=1)
    assert len(r.matches) == 5
    for m in r.matches:
        assert isinstance(m.transform, np.ndarray) and m.transform.shape == (4, 4)
        assert m.transform[3, 3] == pytest.approx(1.0)
        assert 0.9 <= m.score <= 1.0
        assert len(m.faces) >= 20 and min(m.faces) >= 1
        assert m.center.shape == (3,)
    assert '"matches"' in r.to_json()
    assert dict(r.timings)["target_shot"] > 0


def test_arrays_and_brep_string_give_the_same_answer(ref, tgt):
    again = fx.Mesh(tgt.vertices, tgt.triangles, tgt.face_ids, name="arrays")
    a, b = fx.extract(ref, tgt), fx.extract(ref, again)
    assert [m.faces for m in a.matches] == [m.faces for m in b.matches]
    with open(os.path.join(MODELS, "rib_reference.brep")) as f:
        from_string = fx.read_brep_string(f.read(), name="picked faces")
    assert from_string.num_faces == ref.num_faces == 25
    assert len(fx.extract(from_string, tgt).matches) == 5


def test_progress_and_cancel(ref, tgt):
    stages = []

    def record(stage, fraction):
        stages.append((stage, fraction))

    fx.extract(ref, tgt, progress=record)
    names = [s for s, _ in stages]
    assert "target: SHOT descriptors" in names and "ransac" in names and names[-1] == "done"
    assert all(0.0 <= f <= 1.0 for _, f in stages)

    with pytest.raises(fx.Cancelled):
        fx.extract(ref, tgt, progress=lambda s, f: not s.startswith("target"))

    def boom(stage, fraction):
        raise KeyError("from the callback")

    with pytest.raises(KeyError):  # an exception in the callback stops the run and comes back
        fx.extract(ref, tgt, progress=boom)


def test_extract_releases_the_gil(ref, tgt):
    ticks = []
    done = threading.Event()

    def work():
        fx.extract(ref, tgt)
        done.set()

    th = threading.Thread(target=work)
    th.start()
    while not done.is_set():
        ticks.append(time.monotonic())
        time.sleep(0.01)
    th.join()
    assert len(ticks) > 20  # the main thread kept running during the extraction


def test_prepared_target_reuses_its_descriptors(ref, tgt):
    prepared = fx.PreparedTarget(tgt)
    first = fx.extract(ref, prepared)
    assert prepared.descriptions_built == 1
    second = fx.extract(ref, prepared, seed=1)
    assert prepared.descriptions_built == 1  # not recomputed
    assert [m.faces for m in first.matches] == [m.faces for m in second.matches]
    fx.extract(ref, prepared, dense_spacing=0.02)  # other descriptor parameters: a new description
    assert prepared.descriptions_built == 2


def test_features_of_nearby_sizes_share_descriptions_on_the_size_ladder(ref, tgt):
    # the rib and a copy 5 % larger round to one size of the ladder (3 per doubling): one target
    # description for both, where each size has its own without the ladder; each finds the 5 ribs
    v = ref.vertices
    c = 0.5 * (v.min(axis=0) + v.max(axis=0))
    larger = fx.Mesh(c + 1.05 * (v - c), ref.triangles, ref.face_ids, name="rib 1.05x")
    for ladder, descriptions in ((3, 1), (0, 2)):
        prepared = fx.PreparedTarget(tgt)
        found = [len(fx.extract(r, prepared, size_ladder=ladder).matches) for r in (ref, larger)]
        assert prepared.descriptions_built == descriptions
        assert found == [5, 5], (ladder, found)


def test_feature_folder_and_mesh_transfer(tmp_path):
    """Issue 5 from Python: a feature folder, its mesh placed on every boss, written as .inp and .msh."""
    features = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "Resources", "library")
    feature = fx.read_feature(os.path.join(features, "boss"))
    assert feature.mesh.num_elements == 228 and "BOLT_RIGID" in feature.mesh.node_sets
    ref = fx.read_shape(feature.geometry_path)
    tgt = fx.read_target(os.path.join(MODELS, "suite", "bosses.step"), ref)
    result = fx.extract(ref, tgt, seed=1)
    assert result.symmetry == "axisymmetric" and len(result.matches) == 5
    for m in result.matches:
        assert m.rms_error <= m.rms_error_unrefined
        t = fx.transfer_mesh(feature.mesh, m.transform, tgt, spec_json=feature.spec_json)
        assert t.unprojected == 0 and t.max_surface_distance < 1e-6
        assert t.summary_after["inverted"] == 0 and not t.quality_after["inverted"].any()
        assert t.quality_after["scaled_jacobian"].shape == (228,)
    fx.write_inp(t.mesh, str(tmp_path / "boss.inp"))
    fx.write_msh(t.mesh, str(tmp_path / "boss.msh"))
    for name in ("boss.inp", "boss.msh"):
        back = fx.read_fe_mesh(str(tmp_path / name))
        assert np.allclose(back.nodes, t.mesh.nodes) and back.node_sets["BOLT_RIGID"] == t.mesh.node_sets["BOLT_RIGID"]
    with pytest.raises(fx.InputError, match="feature.json"):
        fx.read_feature(str(tmp_path))


def test_box_cut_reference_and_mirror_images_are_reported():
    """Issue 9 from Python: the cut faces a box left on a reference, and mirrored instances."""
    boxcut = fx.read_shape(os.path.join(MODELS, "rib_boxcut_reference.brep"))
    r = fx.extract(boxcut, fx.read_target(os.path.join(MODELS, "ribs_bosses.step"), boxcut), seed=1)
    # the box reached below the plate and above the rib: its four sides are cut; the plate's bottom on
    # the box's -z side is the part's own face, seen on the part the reference was cut out of
    assert r.reference_closed and len(r.reference_cut_faces) == 4 and len(r.matches) == 5
    assert set(r.reference_cut_sides) == {"-x", "+x", "-y", "+y"}
    assert any("cut face" in w for w in r.warnings) and any("part's own faces" in w for w in r.warnings)
    blind = fx.extract(boxcut, fx.read_target(os.path.join(MODELS, "ribs_bosses.step"), boxcut), seed=1, cut_faces_on_target=False)
    assert len(blind.reference_cut_faces) == 5 and "-z" in blind.reference_cut_sides
    pad = fx.read_shape(os.path.join(MODELS, "l_pad_reference.brep"))
    m = fx.extract(pad, fx.read_target(os.path.join(MODELS, "l_pads.step"), pad), seed=1)
    assert m.mirror_searched and not m.reference_mirror_symmetric
    by_x = sorted(m.matches, key=lambda x: x.center[0])
    assert [x.mirrored for x in by_x] == [False, False, True, True]
    assert all((np.linalg.det(x.transform[:3, :3]) < 0) == x.mirrored for x in by_x)
