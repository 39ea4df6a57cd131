"""Drum frames with known angles: the dynamic angle within 0.5 deg, refusals with reasons."""

import math

import numpy as np
import pytest
from scipy import ndimage as ndi

from demcal.measure.drum import DrumCircle, drum_frame, drum_frames, find_circle

H, W = 260, 340
CENTRE, RADIUS = (130.0, 170.0), 110.0


def frame(angle_deg: float, *, level: float = 0.25, falloff: float = 0.0, blur: float = 0.0,
          seed: int = 0) -> np.ndarray:
    """A drum seen through its end wall: grey outside, a dark rim, a bright inside, a dark
    bed below a straight surface through ``level`` x radius below the centre, rising to
    the right at ``angle_deg``; lighting falling off by ``falloff`` from left to right, the
    whole blurred by ``blur`` px (Gaussian sigma) and a little noise."""
    rows, cols = np.mgrid[0:H, 0:W].astype(float)
    r = np.hypot(rows - CENTRE[0], cols - CENTRE[1])
    img = np.full((H, W), 0.55)
    img[r < RADIUS + 5] = 0.08
    img[r < RADIUS] = 0.9
    surface = CENTRE[0] + level * RADIUS - math.tan(math.radians(angle_deg)) * (cols - CENTRE[1])
    img[(r < RADIUS) & (rows > surface)] = 0.2
    img *= 1.0 - falloff * cols / W
    if blur:
        img = ndi.gaussian_filter(img, blur)
    img += np.random.default_rng(seed).normal(0.0, 0.01, img.shape)
    return np.clip(img, 0.0, 1.0)


@pytest.mark.parametrize("angle", [0.0, 18.0, 33.0, -41.0])
def test_known_angles_within_half_a_degree(angle):
    f = drum_frame(frame(angle))
    assert f.refused is None, f.refused
    assert f.angle_deg == pytest.approx(angle, abs=0.5)


def test_the_circle_is_found():
    c = find_circle(frame(30.0))
    assert c is not None
    assert math.hypot(c.row - CENTRE[0], c.col - CENTRE[1]) < 4
    assert abs(c.radius - RADIUS) < 8


def test_lighting_fall_off_and_a_blurred_surface():
    f = drum_frame(frame(35.0, falloff=0.45, blur=2.5), threshold="adaptive")
    assert f.refused is None and f.angle_deg == pytest.approx(35.0, abs=0.5)
    blurred = drum_frame(frame(28.0, blur=3.0))
    assert blurred.angle_deg == pytest.approx(28.0, abs=0.5)


def test_mean_and_standard_error_over_frames_and_a_given_circle():
    circle = DrumCircle(*CENTRE, RADIUS)
    angles = [30.0, 32.0, 34.0, 36.0]
    out = drum_frames([frame(a, seed=k) for k, a in enumerate(angles)], circle=circle)
    assert out.mean_deg == pytest.approx(33.0, abs=0.5)
    assert out.sem_deg == pytest.approx(np.std(angles, ddof=1) / 2, abs=0.3)
    assert out.to_dict()["n_measured"] == 4


def test_frames_are_refused_with_their_reason(tmp_path):
    empty = np.full((H, W), 0.5)
    empty[100:110, 100:110] = 0.4  # no circle in it
    assert "no drum circle found" in drum_frame(empty).refused
    missing = drum_frame(tmp_path / "nope.png")
    assert missing.angle_deg is None and "no such file" in missing.refused
    # a bed up to the top: no free surface
    full = drum_frame(frame(0.0, level=-0.99), circle=DrumCircle(*CENTRE, RADIUS))
    assert full.angle_deg is None and "no free surface" in full.refused
    # a surface that is not a line (a bump in its middle)
    bumpy = frame(20.0)
    bumpy[95:170, 150:190] = 0.2
    out = drum_frame(bumpy, circle=DrumCircle(*CENTRE, RADIUS))
    assert out.angle_deg is None and "not straight" in out.refused
    summary = drum_frames([empty, frame(25.0)])
    assert summary.to_dict()["n_measured"] == 1 and summary.sem_deg is None


def test_the_command_line(tmp_path):
    import json

    from PIL import Image
    from typer.testing import CliRunner

    from demcal.cli import app

    paths = []
    for k, a in enumerate((30.0, 32.0)):
        p = tmp_path / f"f{k}.png"
        Image.fromarray((frame(a, seed=k) * 255).astype(np.uint8)).save(p)
        paths.append(str(p))
    empty = tmp_path / "empty.png"
    Image.fromarray(np.full((H, W), 128, np.uint8)).save(empty)
    out = tmp_path / "drum.json"
    res = CliRunner().invoke(app, ["measure-drum", *paths, str(empty), "--json", str(out)])
    assert res.exit_code == 0, res.output
    data = json.loads(out.read_text())
    assert data["dynamic_aor_deg"] == pytest.approx(31.0, abs=0.5) and data["n_measured"] == 2
    assert "uniform" in data["frames"][2]["refused"]
    assert "dynamic angle = 3" in res.output and "over 2 of 3 frames" in res.output
    bad = CliRunner().invoke(app, ["measure-drum", paths[0], "--circle", "10", "10", "0"])
    assert bad.exit_code == 2 and "--circle" in bad.output
    none = CliRunner().invoke(app, ["measure-drum", str(empty)])
    assert none.exit_code == 3 and "no frame gave an angle" in none.output


def _film(path, angles, *, codec, **frame_options):
    """A video of synthetic drum frames at ``angles`` (deg), one frame each."""
    import av

    with av.open(str(path), "w") as out:
        stream = out.add_stream(codec, rate=25)
        stream.width, stream.height = W, H
        stream.pix_fmt = "gray" if codec == "ffv1" else "yuv420p"
        if codec == "libx264":
            stream.options = {"crf": "18"}  # a lossy film, as a camera writes one
        for k, a in enumerate(angles):
            img = (frame(a, seed=k, **frame_options) * 255).round().astype(np.uint8)
            vf = av.VideoFrame.from_ndarray(img, format="gray")
            out.mux(stream.encode(vf.reformat(format=stream.pix_fmt)))
        out.mux(stream.encode())


@pytest.mark.parametrize(("codec", "suffix"), [("ffv1", ".mkv"), ("libx264", ".mp4")])
def test_a_video_reads_as_its_frames_within_half_a_degree(tmp_path, codec, suffix):
    """Known angles filmed (lossless FFV1, lossy H.264 as a camera writes): each frame read
    within 0.5 deg, named by its place in the film; --every thins the frames."""
    angles = [30.0, 31.5, 29.0, 33.0]
    path = tmp_path / f"drum{suffix}"
    _film(path, angles, codec=codec, falloff=0.3, blur=1.0)
    # the circle given: finding it is tested on stills; here the film's decoding is
    res = drum_frames([str(path)], circle=DrumCircle(*CENTRE, RADIUS))
    assert [f.source for f in res.frames] == [f"{path}#{k}" for k in range(len(angles))]
    assert all(f.refused is None for f in res.frames), [f.refused for f in res.frames]
    assert np.allclose(res.angles, angles, atol=0.5), res.angles
    thin = drum_frames([str(path)], every=3, circle=DrumCircle(*CENTRE, RADIUS))
    assert [f.source for f in thin.frames] == [f"{path}#{k}" for k in (0, 3)]


def test_a_video_through_the_command_line_and_its_refusals(tmp_path):
    import json

    from typer.testing import CliRunner

    from demcal.cli import app
    from demcal.measure.video import video_frames

    path = tmp_path / "drum.mkv"
    _film(path, [20.0, 22.0, 21.0], codec="ffv1")
    out = tmp_path / "drum.json"
    res = CliRunner().invoke(app, ["measure-drum", str(path), "--json", str(out), "--circle",
                                   *map(str, (*CENTRE, RADIUS))])
    assert res.exit_code == 0, res.output
    data = json.loads(out.read_text())
    assert data["n_measured"] == 3 and abs(data["dynamic_aor_deg"] - 21.0) < 0.5
    assert "over 3 of 3 frames" in res.output
    fake = tmp_path / "fake.mp4"
    fake.write_text("not a film")
    bad = CliRunner().invoke(app, ["measure-drum", str(fake)])
    assert bad.exit_code == 2 and "not a readable video" in bad.output
    assert len(bad.output.strip().splitlines()) == 1
    every = CliRunner().invoke(app, ["measure-drum", str(path), "--every", "0"])
    assert every.exit_code == 2 and "--every must be in 1..1000000" in every.output
    with pytest.raises(ValueError, match="more than 2 frames"):
        list(video_frames(path, max_frames=2))
