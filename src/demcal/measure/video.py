"""Frames of a video file as grey images: a drum filmed through its end wall.

Decoding is PyAV's (FFmpeg's decoders: MP4/H.264, AVI, MOV, MKV, WebM, ...). Each decoded
frame becomes a grey image in [0, 1] named ``VIDEO#K`` (K counts the decoded frames from 0),
so a refused frame names where it lies in the film. Frames may be thinned (every N-th) so
that the ones measured lie far enough apart to be independent, which the standard error
over frames assumes.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np

from demcal.errors import InputError
from demcal.safety import MAX_IMAGE_PIXELS, not_regular

__all__ = ["MAX_VIDEO_FRAMES", "VIDEO_SUFFIXES", "is_video", "video_frames"]

#: file name endings read as videos (anything else is read as a still frame)
VIDEO_SUFFIXES = (".mp4", ".m4v", ".avi", ".mov", ".mkv", ".webm", ".mpg", ".mpeg", ".wmv")
#: frames taken from one video at most (after thinning): a longer film is refused, not cut
MAX_VIDEO_FRAMES = 5000


def is_video(path: str | Path) -> bool:
    """Whether ``path`` names a video file by its ending."""
    return Path(path).suffix.lower() in VIDEO_SUFFIXES


def _open(path: Path):
    """The opened container of a readable video with frames of a sane size."""
    import av

    if not path.is_file() or (why := not_regular(path)):
        raise InputError(f"video {path}: {'no such file' if not path.exists() else why}")
    try:
        container = av.open(str(path))
    except (av.FFmpegError, OSError, ValueError) as exc:
        raise InputError(f"video {path}: not a readable video ({type(exc).__name__})") from None
    if not container.streams.video:
        container.close()
        raise InputError(f"video {path}: holds no video stream")
    ctx = container.streams.video[0].codec_context
    if ctx.width * ctx.height > MAX_IMAGE_PIXELS:
        container.close()
        raise InputError(f"video {path}: frames of {ctx.width} x {ctx.height} px exceed "
                         f"{MAX_IMAGE_PIXELS} px")
    return container


def video_frames(path: str | Path, *, every: int = 1,
                 max_frames: int = MAX_VIDEO_FRAMES) -> Iterator[tuple[str, np.ndarray]]:
    """The frames of a video: ``(name, grey image)`` for every ``every``-th decoded frame.

    Parameters
    ----------
    path : path
        The video file.
    every : int
        Take one decoded frame in ``every`` (1: all).
    max_frames : int
        Most frames taken; a video with more is refused (say ``every`` to thin it).

    Raises
    ------
    InputError
        One line: no such file, not a readable video, no video stream, frames too large,
        too many frames.
    """
    import av

    path = Path(path)
    if not 1 <= every <= 1_000_000:
        raise InputError(f"every must be in 1..1000000; got {every}")
    container = _open(path)
    with container:
        stream = container.streams.video[0]
        taken = 0
        try:
            for k, frame in enumerate(container.decode(stream)):
                if k % every:
                    continue
                if taken == max_frames:
                    raise InputError(f"video {path}: more than {max_frames} frames; take "
                                     "fewer (--every N)")
                taken += 1
                gray = frame.to_ndarray(format="gray").astype(float) / 255.0
                yield f"{path}#{k}", gray
        except av.FFmpegError as exc:
            raise InputError(f"video {path}: decoding failed at frame {taken} "
                             f"({type(exc).__name__})") from None
    if taken == 0:
        raise InputError(f"video {path}: no frame decoded")
