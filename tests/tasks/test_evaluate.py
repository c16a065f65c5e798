import json

import numpy as np
import pytest

from aldpat.core.accuracy import accuracy, coordinate_keys, match_accuracy, reference_calls
from aldpat.tasks import get_task
from aldpat.tasks.preview import CALL_RGB, GROUND_RIGHT, OBJECT_RIGHT, TYPE_I, TYPE_II, calls_rgba
from tests.conftest import write_xyz


def test_hand_computed_confusion():
    # 4 ground (one rejected), 2 objects (one accepted)
    acc = accuracy([1, 1, 1, 1, 0, 0], [1, 1, 1, 0, 1, 0])
    assert (acc.ground_as_ground, acc.ground_as_object, acc.object_as_ground, acc.object_as_object) == (3, 1, 1, 1)
    assert acc.type1 == pytest.approx(25.0) and acc.type2 == pytest.approx(50.0)
    assert acc.total == pytest.approx(100 * 2 / 6)
    # kappa = (po - pe) / (1 - pe), po = 4/6, pe = (4*4 + 2*2) / 36
    assert acc.kappa == pytest.approx((4 / 6 - 20 / 36) / (1 - 20 / 36))


def test_duplicates_count_as_often_as_they_occur():
    ref = np.array([[0, 0, 0], [0, 0, 0], [1, 1, 1], [2, 2, 2]])
    ref_ground = np.array([True, True, False, True])
    # the terrain result holds the duplicated point once and the object point
    res = np.array([[0, 0, 0], [1, 1, 1]])
    acc, unmatched = match_accuracy(ref, ref_ground, res, np.ones(2, bool))
    assert (acc.ground_as_ground, acc.ground_as_object, acc.object_as_ground, acc.object_as_object) == (1, 2, 1, 0)
    assert unmatched == 0
    # a result point that is not in the reference is not counted
    acc, unmatched = match_accuracy(ref, ref_ground, np.vstack([res, [[9, 9, 9]]]), np.ones(3, bool))
    assert unmatched == 1 and acc.n == 4


def test_keys_snap_coordinates_to_the_tolerance():
    k = coordinate_keys(np.array([512203.97000000003, 512203.97]), np.array([1.0, 1.0]), np.array([2.0, 2.0]), 0.001)
    assert (k[0] == k[1]).all()


def test_a_tolerance_whose_keys_wrap_is_refused_not_matched(tmp_path, samp24):
    """At --tolerance 1e-300 every key wrapped to one value: a shifted result "matched" every
    reference point, scored, exit 0, where it matches none."""
    data = np.loadtxt(samp24)
    shifted = write_xyz(tmp_path / "shifted.txt", data[:, :3] + [1000.0, 0.0, 0.0])
    report = get_task("evaluate")([shifted], reference=str(samp24), tolerance=1e-300)
    assert report.exit_code == 1
    assert "steps of the tolerance 1e-300 m from 0" in report.results[0].error
    assert "use a larger --tolerance" in report.results[0].error
    # a tolerance below the coordinates' precision still matches them exactly
    same = write_xyz(tmp_path / "same.txt", data[:, :3])
    report = get_task("evaluate")([same], reference=str(samp24), tolerance=1e-12)
    assert report.exit_code == 0 and report.results[0].records[0]["total"] == pytest.approx(
        100 * (data[:, 3] != 0).sum() / len(data))


def test_evaluate_a_terrain_file_against_isprs_labels(tmp_path, samp24):
    data = np.loadtxt(samp24)
    ground = data[:, 3] == 0
    rng = np.random.default_rng(0)
    drop = ground & (rng.random(len(data)) < 0.1)       # Type I errors
    accept = ~ground & (rng.random(len(data)) < 0.05)   # Type II errors
    keep = (ground & ~drop) | accept
    result = write_xyz(tmp_path / "terrain.txt", data[keep][:, :3][rng.permutation(int(keep.sum()))])
    report = get_task("evaluate")([result], reference=str(samp24))
    rec = report.results[0].records[0]
    assert rec["ground_as_object"] == drop.sum() and rec["object_as_ground"] == accept.sum()
    assert rec["type1"] == pytest.approx(100 * drop.sum() / ground.sum(), abs=1e-4)
    assert rec["type2"] == pytest.approx(100 * accept.sum() / (~ground).sum(), abs=1e-4)
    assert rec["total"] == pytest.approx(100 * (drop.sum() + accept.sum()) / len(data), abs=1e-4)


def test_a_result_matching_no_reference_point_is_refused_not_scored(tmp_path, samp24):
    """Another sample's reference (or shifted coordinates) matches nothing: its Type I of 100 %
    would read as the filter's; a result matching some points is scored with a warning."""
    data = np.loadtxt(samp24)
    shifted = write_xyz(tmp_path / "shifted.txt", data[:, :3] + [1000.0, 0.0, 0.0])
    report = get_task("evaluate")([shifted], reference=str(samp24))
    assert report.exit_code == 1
    assert f"none of its {len(data):,} points matches a point of samp24.txt" in report.results[0].error
    some = write_xyz(tmp_path / "some.txt", np.vstack([data[:10, :3], data[10:20, :3] + [1000.0, 0.0, 0.0]]))
    report = get_task("evaluate")([some], reference=str(samp24))
    assert report.exit_code == 0 and report.results[0].records[0]["unmatched"] == 10


def test_evaluate_a_classified_las_and_json_output(tmp_path, samp24, runner, cli):
    laz = tmp_path / "samp24.laz"
    assert runner.invoke(cli, ["convert", str(samp24), "--out-format", "laz", "--odir", str(tmp_path)]).exit_code == 0
    import laspy

    las = laspy.read(laz)
    labels = np.loadtxt(samp24)[:, 3]
    las.classification = np.where(labels == 0, 2, 1)  # perfect classification
    las.write(laz)
    out = runner.invoke(cli, ["evaluate", str(laz), "--reference", str(samp24), "--json"])
    assert out.exit_code == 0, out.output
    rec = json.loads(out.output.strip())
    assert rec["total"] == 0.0 and rec["kappa"] == 1.0 and rec["points"] == len(labels)
    assert set(rec) >= {"type1", "type2", "total", "kappa"}


def test_a_classified_text_result_is_recognised(tmp_path, samp24):
    """What `filter --result classified --marks` writes: x y z i class mark."""
    data = np.loadtxt(samp24)
    ground = data[:, 3] == 0
    cls = np.where(ground, 2, 1)
    cls[:10] = np.where(ground[:10], 1, 2)  # ten mistakes
    marks = np.where(cls == 2, 0, 5)
    rows = np.column_stack([data[:, :3], np.full(len(data), 7), cls, marks])
    result = write_xyz(tmp_path / "c.txt", rows, fmt="%.2f")
    rec = get_task("evaluate")([result], reference=str(samp24)).results[0].records[0]
    assert rec["ground_as_object"] + rec["object_as_ground"] == 10
    terrain = get_task("evaluate")([result], reference=str(samp24), mode="terrain").results[0].records[0]
    assert terrain["type2"] == 100.0


def test_the_reference_is_read_once_for_many_results(tmp_path, samp24):
    from aldpat.tasks.evaluate import _reference_labels

    data = np.loadtxt(samp24)
    results = [write_xyz(tmp_path / f"r{k}.txt", data[data[:, 3] == 0][k::3, :3]) for k in range(3)]
    _reference_labels.cache_clear()
    report = get_task("evaluate")(results, reference=str(samp24))
    assert [r.records[0]["ground_as_ground"] for r in report.results] == [
        len(data[data[:, 3] == 0][k::3]) for k in range(3)]
    info = _reference_labels.cache_info()
    assert (info.misses, info.hits) == (1, 2)


def test_reference_calls_agree_with_the_counts():
    rng = np.random.default_rng(3)
    ref = rng.integers(0, 40, (500, 3))  # many repeated keys
    ref_ground = rng.random(500) < 0.6
    res = ref[rng.random(500) < 0.7]
    res_ground = rng.random(len(res)) < 0.8
    calls = reference_calls(ref, ref_ground, res, res_ground)
    assert accuracy(ref_ground, calls) == match_accuracy(ref, ref_ground, res, res_ground)[0]
    # a duplicated ground point held once: one of the two is called ground, the first
    one = reference_calls(np.array([[0, 0, 0], [0, 0, 0]]), np.array([True, True]), np.array([[0, 0, 0]]),
                          np.array([True]))
    assert one.tolist() == [True, False]


def test_map_colours_each_call_where_it_is():
    # south-west ground called ground, south-east ground rejected, north-west object accepted,
    # north-east object rejected; 10 m apart: 5 m pixels, 3 x 3, enlarged to 600 x 600
    x = np.array([0.0, 10.0, 0.0, 10.0])
    y = np.array([0.0, 0.0, 10.0, 10.0])
    rgba = calls_rgba(x, y, np.array([True, True, False, False]), np.array([True, False, True, False]), 1000)
    assert rgba.shape == (600, 600, 4) and (rgba[..., 3] == 255).all()
    corners = {"nw": rgba[0, 0, :3], "ne": rgba[0, -1, :3], "sw": rgba[-1, 0, :3], "se": rgba[-1, -1, :3]}
    expected = {"nw": TYPE_II, "ne": OBJECT_RIGHT, "sw": GROUND_RIGHT, "se": TYPE_I}
    for where, call in expected.items():
        assert corners[where].tolist() == CALL_RGB[call].tolist(), where


def test_evaluate_map_of_sample_24(tmp_path, samp24):
    from PIL import Image

    data = np.loadtxt(samp24)
    called = data.copy()
    called[:, 3] = np.where(data[:, 0] < np.median(data[:, 0]), 0, 1)  # west half called ground
    np.savetxt(tmp_path / "called.txt", np.c_[called[:, :3], np.where(called[:, 3] == 0, 2, 1)],
               fmt="%.2f %.2f %.2f %d")
    report = get_task("evaluate")([tmp_path / "called.txt"], reference=str(samp24), map=str(tmp_path / "m.png"))
    assert report.exit_code == 0, [r.error for r in report.results]
    with Image.open(tmp_path / "m.png") as im:
        pixels = np.asarray(im)[..., :3].reshape(-1, 3)
    found = {call for call in range(4) if (pixels == CALL_RGB[call]).all(axis=1).any()}
    assert found == {OBJECT_RIGHT, GROUND_RIGHT, TYPE_I, TYPE_II}
    west = np.asarray(Image.open(tmp_path / "m.png"))[:, :100, :3].reshape(-1, 3)
    east = np.asarray(Image.open(tmp_path / "m.png"))[:, -100:, :3].reshape(-1, 3)
    # west: ground right or objects accepted only; east: objects right or ground rejected only
    assert not (west == CALL_RGB[TYPE_I]).all(axis=1).any() and not (east == CALL_RGB[TYPE_II]).all(axis=1).any()


def test_one_map_for_several_results_needs_stem(tmp_path, samp24):
    from aldpat.errors import UsageError

    write_xyz(tmp_path / "a.txt", np.loadtxt(samp24)[:10, :3])
    write_xyz(tmp_path / "b.txt", np.loadtxt(samp24)[10:20, :3])
    with pytest.raises(UsageError, match="stem"):
        get_task("evaluate")([tmp_path / "a.txt", tmp_path / "b.txt"], reference=str(samp24),
                             map=str(tmp_path / "m.png"))
    report = get_task("evaluate")([tmp_path / "a.txt", tmp_path / "b.txt"], reference=str(samp24),
                                  map=str(tmp_path / "{stem}_calls.png"))
    assert report.exit_code == 0 and (tmp_path / "a_calls.png").exists() and (tmp_path / "b_calls.png").exists()


def test_a_las_terrain_output_is_class_2_and_evaluates_as_the_classified_output(tmp_path):
    """A LAS terrain output kept its points' input classes (1, 64...), so ``evaluate`` (which reads
    a LAS by its class 2) found no ground in it, and neither would any tool taking class 2 for
    ground. In fresh processes, on a LAS 1.4 strip with vendor classes and noise: the terrain and
    non-terrain outputs now hold the classified output's points and classes, split at class 2,
    and the terrain output scores as the classified one."""
    import laspy

    from tests.cli.fresh import TEST_DATA, aldpat

    las = laspy.convert(laspy.read(TEST_DATA / "fsite5_strip.laz"), point_format_id=6, file_version="1.4")
    rng = np.random.default_rng(5)
    las.classification = rng.choice(np.array([1, 64, 200], np.uint8), len(las.points))
    las.classification[rng.random(len(las.points)) < 0.01] = 7
    las.write(tmp_path / "vendor.laz")
    aldpat("filter", "gapm", "vendor.laz", "--odir", "all", cwd=tmp_path).ok()
    aldpat("filter", "gapm", "vendor.laz", "--result", "both", "--odir", "split", cwd=tmp_path).ok()
    every = laspy.read(tmp_path / "all" / "vendor_gapm.laz")
    terrain = laspy.read(tmp_path / "split" / "vendor_gapm.laz")
    objects = laspy.read(tmp_path / "split" / "vendor_gapm_nt.laz")
    ground = np.asarray(every.classification) == 2
    assert ground.mean() > 0.5 and set(np.unique(terrain.classification)) == {2}
    assert np.array_equal(np.asarray(terrain.X), np.asarray(every.X)[ground])
    assert np.array_equal(np.asarray(objects.classification), np.asarray(every.classification)[~ground])
    assert 7 in set(np.unique(objects.classification))  # noise stays noise
    # the reference: the classified output's own calls, ground 0 and object 1
    reference = np.column_stack([every.x, every.y, every.z, np.where(ground, 0, 1)])
    np.savetxt(tmp_path / "reference.txt", reference, fmt="%.2f %.2f %.2f %d")
    scores = [json.loads(aldpat("evaluate", result, "--reference", "reference.txt", "--json", cwd=tmp_path).ok().stdout)
              for result in ("all/vendor_gapm.laz", "split/vendor_gapm.laz")]
    assert scores[0]["total"] == scores[1]["total"] == 0.0
