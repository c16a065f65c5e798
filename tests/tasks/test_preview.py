"""aldpat preview: the hillshade of any grid aldpat writes, and plan views of points by elevation
or class, as PNGs a person can look at."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from aldpat.core.grid_extent import GridSpec
from aldpat.errors import InputMissingError
from aldpat.io.esri_grid import write_float_grid
from aldpat.io.geotiff import write_geotiff
from aldpat.io.surfer import write_surfer
from aldpat.tasks import get_task
from tests.cli.fresh import aldpat

SPEC = GridSpec(500000.0, 4000000.0, 2.0, 2.0, 40, 30)


def plane(a: float = 0.3, b: float = -0.2) -> np.ndarray:
    """z = a x + b y on SPEC's nodes, rows from the south."""
    rows, cols = np.mgrid[0:SPEC.ny, 0:SPEC.nx]
    return a * cols * SPEC.dx + b * rows * SPEC.dy + 100.0


def lambert(a: float, b: float, azimuth: float, altitude: float) -> float:
    """The shade of the plane z = a x + b y, from its normal and the sun's direction."""
    n = np.array([-a, -b, 1.0]) / np.sqrt(a * a + b * b + 1.0)
    az, alt = np.radians(azimuth), np.radians(altitude)
    sun = np.array([np.sin(az) * np.cos(alt), np.cos(az) * np.cos(alt), np.sin(alt)])
    return 255.0 * max(0.0, float(n @ sun))


@pytest.mark.parametrize("azimuth, altitude", [(315.0, 45.0), (90.0, 30.0), (200.0, 60.0)])
def test_hillshade_of_a_plane_is_its_lambert_shade(tmp_path, azimuth, altitude):
    write_surfer(tmp_path / "p.grd", plane(), SPEC)
    report = get_task("preview")([tmp_path / "p.grd"], azimuth=azimuth, altitude=altitude)
    assert report.exit_code == 0, [r.error for r in report.results]
    img = np.asarray(Image.open(tmp_path / "p_hillshade.png"))
    assert img.shape == (SPEC.ny, SPEC.nx, 4) and (img[..., 3] == 255).all()
    inner = img[1:-1, 1:-1, 0].astype(float)  # the edges repeat outward, as GIS tools do
    assert np.abs(inner - lambert(0.3, -0.2, azimuth, altitude)).max() <= 0.5


def test_every_grid_format_gives_the_same_picture_and_blanks_are_transparent(tmp_path):
    z = plane()
    z[10:14, 20:25] = np.nan
    z[5, 5] += 3.0  # a bump to shade
    write_surfer(tmp_path / "g.grd", z, SPEC)
    write_float_grid(tmp_path / "g.flt", z, SPEC)
    write_geotiff(tmp_path / "g.tif", z, SPEC)
    pictures = []
    for name in ("g.grd", "g.flt", "g.tif"):
        odir = tmp_path / name.replace(".", "_")
        assert get_task("preview")([tmp_path / name], odir=str(odir)).exit_code == 0
        pictures.append(np.asarray(Image.open(odir / "g_hillshade.png")))
    assert all(np.array_equal(p, pictures[0]) for p in pictures[1:])
    alpha = pictures[0][..., 3]
    assert np.array_equal(alpha == 0, np.isnan(z)[::-1])  # north up: row 0 is the northern row


def test_a_south_up_geotiff_gives_the_north_up_picture_and_a_rotated_one_is_refused(tmp_path):
    """GDAL writes and reads rasters whose first row is the southern one (a positive y pixel
    size): the same grid with its rows the other way round, so the same picture and world file
    as the north-up file. A rotated raster has no lattice of x and y: refused by name."""
    import rasterio
    from rasterio.transform import Affine

    z = plane()
    z[10:14, 20:25] = np.nan
    write_geotiff(tmp_path / "north.tif", z, SPEC)
    with rasterio.open(tmp_path / "north.tif") as ds:
        profile, band = ds.profile, ds.read(1)
    south_first = Affine(SPEC.dx, 0.0, SPEC.xmin - SPEC.dx / 2, 0.0, SPEC.dy, SPEC.ymin - SPEC.dy / 2)
    with rasterio.open(tmp_path / "south.tif", "w", **{**profile, "transform": south_first}) as ds:
        ds.write(band[::-1], 1)
    rotated = Affine(SPEC.dx, 0.5, SPEC.xmin, 0.5, -SPEC.dy, SPEC.ymax)
    with rasterio.open(tmp_path / "turned.tif", "w", **{**profile, "transform": rotated}) as ds:
        ds.write(band, 1)
    report = get_task("preview")([tmp_path / "north.tif", tmp_path / "south.tif", tmp_path / "turned.tif"])
    assert [r.ok for r in report.results] == [True, True, False]
    assert "rotated, sheared or run west" in str(report.results[2].error)
    north, south = (np.asarray(Image.open(tmp_path / f"{n}_hillshade.png")) for n in ("north", "south"))
    assert np.array_equal(north, south) and (north[..., 3] == 0).sum() == 20
    assert (tmp_path / "north_hillshade.pgw").read_text() == (tmp_path / "south_hillshade.pgw").read_text()


def test_a_grid_longer_than_the_picture_is_read_at_every_kth_node(tmp_path, monkeypatch):
    """A county's mosaic is tens of thousands of nodes a side: past GRID_LONGEST its hillshade
    is made of every k-th node, placed where those nodes lie, blanks kept blank."""
    from aldpat.tasks import preview

    monkeypatch.setattr(preview, "GRID_LONGEST", 14)  # SPEC is 40 x 30 nodes: every 3rd node
    z = plane()
    z[:, 10] = np.nan  # column 10 is a node column the picture samples
    write_geotiff(tmp_path / "g.tif", z, SPEC)
    assert get_task("preview")([tmp_path / "g.tif"]).exit_code == 0
    img = np.asarray(Image.open(tmp_path / "g_hillshade.png"))
    assert img.shape == (10, 13, 4)  # the 40th column is left out: whole steps only
    assert (img[:, 3, 3] == 0).all() and (img[:, [0, 1, 2, 4, 5], 3] == 255).all()  # node column 1 + 3 k
    world = [float(v) for v in (tmp_path / "g_hillshade.pgw").read_text().split()]
    # pixel (0, 0) is the node of column 1 and the northern row 28 (rows 1 + 3 k from the north)
    assert world == [3 * SPEC.dx, 0.0, 0.0, -3 * SPEC.dy, SPEC.xmin + 1 * SPEC.dx, SPEC.ymin + 28 * SPEC.dy]


def test_demo_grid_preview_in_a_fresh_process_shows_the_terrain(tmp_path, samp24):
    aldpat("grid", samp24, "--cell", "1", "--odir", tmp_path).ok()
    aldpat("preview", tmp_path / "samp24_linear.grd").ok()
    from aldpat.io.surfer import read_surfer

    z, spec = read_surfer(tmp_path / "samp24_linear.grd")
    img = np.asarray(Image.open(tmp_path / "samp24_linear_hillshade.png"))
    assert img.shape[:2] == (spec.ny, spec.nx)
    # independently: the Lambert shade of each node's normal from central differences
    north = z[::-1]
    gy, gx = np.gradient(north, spec.dy, spec.dx)
    n = np.dstack([-gx, gy, np.ones_like(gx)])  # rows run south, so d/dnorth = -d/drow
    n /= np.linalg.norm(n, axis=2, keepdims=True)
    az, alt = np.radians(315.0), np.radians(45.0)
    sun = np.array([np.sin(az) * np.cos(alt), np.cos(az) * np.cos(alt), np.sin(alt)])
    expected = 255.0 * np.clip(n @ sun, 0.0, None)
    ok = np.isfinite(expected) & (img[..., 3] == 255)
    ours = img[..., 0].astype(float)[ok]
    assert ok.sum() > 0.8 * ok.size
    assert np.corrcoef(ours, expected[ok])[0, 1] > 0.9  # the same light and shadow
    assert abs(np.median(ours) - np.median(expected[ok])) < 10  # of 255 gray levels


def test_plan_view_by_class(tmp_path):
    rng = np.random.default_rng(2)
    x, y = rng.uniform(0, 100, 20000), rng.uniform(0, 50, 20000)
    cls = np.where(x < 50, 2, 1)
    np.savetxt(tmp_path / "c.txt", np.c_[x, y, rng.normal(10, 1, x.size), np.zeros(x.size), cls],
               fmt="%.2f %.2f %.2f %d %d")
    assert get_task("preview")([tmp_path / "c.txt"], color_by="class", size=200).exit_code == 0
    img = np.asarray(Image.open(tmp_path / "c_plan.png"))
    assert img.shape[1] <= 200 and img.shape[1] == pytest.approx(2 * img.shape[0], abs=2)
    left, right = img[:, : img.shape[1] // 2 - 2], img[:, img.shape[1] // 2 + 2:]
    drawn_left, drawn_right = left[left[..., 3] == 255], right[right[..., 3] == 255]
    assert len(drawn_left) > 0.9 * left[..., 3].size and len(drawn_right) > 0.9 * right[..., 3].size
    assert (drawn_left[:, :3] == (60, 160, 60)).all() and (drawn_right[:, :3] == (160, 160, 160)).all()


def test_plan_view_by_class_needs_classes(tmp_path, samp24):
    report = get_task("preview")([samp24], color_by="class", odir=str(tmp_path))
    assert report.exit_code == 1 and "needs classes" in report.results[0].error
    with pytest.raises(InputMissingError):
        from aldpat.tasks.preview import read_grid

        read_grid(tmp_path / "missing.grd")
