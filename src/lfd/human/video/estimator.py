"""Loading MediaPipe Pose 0.10.14 (BlazePose GHUM landmark model ``full`` or ``heavy``) and reading
its results as arrays.

``full`` ships inside the wheel. ``heavy`` does not (MediaPipe would download it from Google on
first use); lfd never downloads at run time: it uses ``pose_landmark_heavy.tflite`` from MediaPipe's
module folder (``mediapipe/modules/pose_landmark/``) or a file you pass, checked against
:data:`HEAVY_MODEL_SHA256`, and copies a passed file into the module folder (where MediaPipe's graph
looks for it). ``python scripts/get_pose_model.py`` provisions it from the official npm package
:data:`HEAVY_MODEL_NPM` (``npm pack``, checksum verified).

MediaPipe 0.10.14's Python layer predates protobuf 5; every :func:`load_pose_estimator` call
patches it process-wide (idempotent): the removed ``GetPrototype`` calls are restored on
protobuf's symbol database and message factory, and ``SolutionBase._modify_calculator_options``
is replaced by a version that works on protobuf 4 to 7. Install with ``pip install "lfd[video]"``.

MediaPipe's C++ code (absl logging, TensorFlow Lite) writes log lines straight to the process's
standard error from its own threads while a graph starts ("INFO: Created TensorFlow Lite XNNPACK
delegate for CPU", "W0000 ... inference_feedback_manager.cc ...]"), in the middle of progress bars.
:func:`load_pose_estimator` builds the graph and waits until it is idle (every calculator opened)
with standard error captured, then hands those lines to the :mod:`logging` logger
``lfd.human.video.mediapipe``: start-up chatter at DEBUG, any other warning or error at its own
level (shown by default); other output of the window is written back to standard error.
"""

from __future__ import annotations

import contextlib
import ctypes
import logging
import os
import re
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from lfd.checks import positive_int
from lfd.io.files import sha256_file, write_bytes_atomic

__all__ = [
    "HEAVY_MODEL_NPM",
    "HEAVY_MODEL_SHA256",
    "MODELS",
    "heavy_model_path",
    "install_heavy_model",
    "landmarks_of",
    "load_people_estimator",
    "load_pose_estimator",
    "people_of",
    "route_cpp_log",
]

#: Landmark models: name -> MediaPipe's ``model_complexity``.
MODELS = {"full": 1, "heavy": 2}
#: The official npm package that ships ``pose_landmark_heavy.tflite`` (its ``full`` model is
#: byte-identical to the wheel's).
HEAVY_MODEL_NPM = "@mediapipe/pose@0.5.1675469404"
HEAVY_MODEL_BYTES = 27_709_200
HEAVY_MODEL_SHA256 = "59e42d71bcd44cbdbabc419f0ff76686595fd265419566bd4009ef703ea8e1fe"
_HOW_TO_GET = (
    f"get it with `python scripts/get_pose_model.py` (npm pack {HEAVY_MODEL_NPM}, checksum verified) "
    "or pass pose.heavy_model=PATH / heavy_model=PATH of a verified copy"
)
_NO_MEDIAPIPE = (
    "the video pose estimator needs MediaPipe 0.10.14 without its declared dependencies: "
    'pip install -e ".[video]" && lfd-install-mediapipe'
)
_verified: dict[tuple[str, int, int], bool] = {}

#: Where MediaPipe's C++ log lines go (:func:`load_pose_estimator`).
LOGGER = logging.getLogger("lfd.human.video.mediapipe")
#: A C++ log line: absl's ``W0000 00:00:1796552345.024021   14440 file.cc:114] message`` (the seconds since
#: the epoch, before absl is initialised) or
#: TensorFlow Lite's ``INFO: message``; the group is the severity.
_CPP_LOG = re.compile(
    r"^(?:(?P<absl>[IWEF])\d{4} \d\d:\d\d:\d+\.\d+\s+\d+ [^\s:]+:\d+\]|(?P<tflite>INFO|WARNING|ERROR|FATAL): )"
)
#: Start-up lines of every run, which say nothing to a user: logged at DEBUG.
_STARTUP_CHATTER = (
    "Created TensorFlow Lite XNNPACK delegate",
    "All log messages before absl::InitializeLog() is called",
    "inference_feedback_manager.cc",
    "gl_context",
    "GL version",
)
_LEVELS = {"I": logging.DEBUG, "W": logging.WARNING, "E": logging.ERROR, "F": logging.CRITICAL}


def route_cpp_log(text: str) -> str:
    """Log MediaPipe's C++ log lines of ``text`` to :data:`LOGGER`; returns the rest of ``text``."""
    rest = []
    for line in text.split("\n"):
        match = _CPP_LOG.match(line)
        if match is None:
            rest.append(line)
            continue
        severity = (match.group("absl") or match.group("tflite"))[0]
        level = logging.DEBUG if any(c in line for c in _STARTUP_CHATTER) else _LEVELS[severity]
        LOGGER.log(level, "%s", line.rstrip())
    return "\n".join(rest)


@contextlib.contextmanager
def _stderr_to_logging() -> Iterator[None]:
    """Capture the process's standard error (file descriptor 2) in a temporary file; afterwards route
    MediaPipe's lines to :data:`LOGGER` (:func:`route_cpp_log`) and write the rest back."""
    with contextlib.suppress(AttributeError, OSError, ValueError):
        sys.stderr.flush()
    try:
        saved = os.dup(2)
    except OSError:  # no standard error to capture
        yield
        return
    with tempfile.TemporaryFile() as capture:
        os.dup2(capture.fileno(), 2)
        try:
            yield
        finally:
            with contextlib.suppress(AttributeError, OSError, ValueError):
                sys.stderr.flush()
            with contextlib.suppress(OSError, AttributeError, TypeError):
                ctypes.CDLL(None).fflush(None)
            os.dup2(saved, 2)
            os.close(saved)
            capture.seek(0)
            rest = route_cpp_log(capture.read().decode(errors="replace"))
            if rest:
                with contextlib.suppress(AttributeError, OSError, ValueError):
                    sys.stderr.write(rest)
                    sys.stderr.flush()


def _mediapipe_root() -> Path:
    """The installed ``mediapipe`` package folder (found without importing it)."""
    import importlib.util

    spec = importlib.util.find_spec("mediapipe")
    if spec is None or not spec.submodule_search_locations:
        raise ImportError(_NO_MEDIAPIPE)
    return Path(next(iter(spec.submodule_search_locations)))


def heavy_model_path() -> Path:
    """Where MediaPipe's pose graph loads the heavy model from (``modules/pose_landmark/`` of the install)."""
    return _mediapipe_root() / "modules" / "pose_landmark" / "pose_landmark_heavy.tflite"


def _is_heavy_model(path: Path) -> bool:
    """``path`` has the size and SHA-256 of the published heavy model (hashed once per file version)."""
    st = path.stat()
    key = (str(path.resolve()), st.st_size, st.st_mtime_ns)
    if key not in _verified:
        _verified[key] = st.st_size == HEAVY_MODEL_BYTES and sha256_file(path) == HEAVY_MODEL_SHA256
    return _verified[key]


def install_heavy_model(source: str | os.PathLike | None = None) -> Path:
    """The verified heavy model in MediaPipe's module folder, copied there from ``source`` if needed.

    Args:
        source: a ``pose_landmark_heavy.tflite`` (27,709,200 bytes, SHA-256 :data:`HEAVY_MODEL_SHA256`);
            None = it must already be in the module folder.

    Returns:
        :func:`heavy_model_path`.

    Raises:
        FileNotFoundError: no model at ``source``, or none installed and no ``source`` (the
            message says how to get it). ValueError: a file with the wrong size or checksum.
        PermissionError: the module folder is not writable (copy the file there by hand).
    """
    target = heavy_model_path()
    if source is not None:
        src = Path(source).expanduser()
        if not src.is_file():
            raise FileNotFoundError(f"heavy_model: no file at {src}; {_HOW_TO_GET}")
        if not _is_heavy_model(src):
            raise ValueError(
                f"heavy_model: {src} is not pose_landmark_heavy.tflite of {HEAVY_MODEL_NPM} "
                f"(expected {HEAVY_MODEL_BYTES} bytes, sha256 {HEAVY_MODEL_SHA256})"
            )
        if not (target.is_file() and _is_heavy_model(target)):
            write_bytes_atomic(target, src.read_bytes())
        return target
    if not target.is_file():
        raise FileNotFoundError(
            f"pose.model=heavy: {target} is missing (MediaPipe's wheel ships only the full model); {_HOW_TO_GET}"
        )
    if not _is_heavy_model(target):
        raise ValueError(
            f"pose.model=heavy: {target} is not the published heavy model (sha256 {HEAVY_MODEL_SHA256}); "
            f"delete it and {_HOW_TO_GET}"
        )
    return target


def _protobuf_compat() -> None:
    """Restore the two protobuf calls MediaPipe 0.10.14's Python layer uses.

    ``GetPrototype`` was deprecated (protobuf 4.25, with a warning on every use) and then removed
    from the symbol database / message factory (replaced by ``message_factory.GetMessageClass``),
    and ``FieldDescriptor.label`` by ``is_repeated``; the solution API uses both when it sets
    calculator options and reads output packets.
    """
    from google.protobuf import message_factory, symbol_database

    for cls in (symbol_database.SymbolDatabase, message_factory.MessageFactory):
        cls.GetPrototype = lambda self, descriptor: message_factory.GetMessageClass(descriptor)


def _set_calculator_options(self, config, params) -> None:
    """Replacement of ``SolutionBase._modify_calculator_options`` that works on protobuf 4 to 7."""
    from mediapipe.python.solution_base import CALCULATOR_TO_OPTIONS

    nested: dict[str, list] = {}
    for key, value in params.items():
        node_name, field = key.split(".")
        nested.setdefault(node_name, []).append((field, value))

    def apply(options, fields):
        for field, value in fields:
            fd = options.DESCRIPTOR.fields_by_name[field]
            repeated = fd.is_repeated if hasattr(fd, "is_repeated") else fd.label == fd.LABEL_REPEATED
            if value is None:
                options.ClearField(field)
            elif repeated:
                options.ClearField(field)
                getattr(options, field).extend(value)
            else:
                setattr(options, field, value)

    done = 0
    for node in config.node:
        if node.name not in nested:
            continue
        options_type = CALCULATOR_TO_OPTIONS.get(node.calculator)
        if options_type is None:
            raise ValueError(f"Modifying the calculator options of {node.name} is not supported.")
        if node.node_options:
            for elem in node.node_options:
                if elem.type_url.split("/")[-1] == options_type.DESCRIPTOR.full_name:
                    options = options_type.FromString(elem.value)
                    apply(options, nested[node.name])
                    elem.value = options.SerializeToString()
                    break
            else:
                options = options_type()
                apply(options, nested[node.name])
                node.node_options.add().Pack(options)
        else:
            apply(node.options.Extensions[options_type.ext], nested[node.name])
        done += 1
    if done < len(nested):
        raise ValueError("Not all calculator params are valid.")


def _check_model(model: str, heavy_model) -> None:
    """``model`` is one of :data:`MODELS` and, for ``"heavy"``, the verified model is installed."""
    if model not in MODELS:
        raise ValueError(f"pose.model must be one of {', '.join(MODELS)}, got {model!r}")
    if model == "full" and heavy_model is not None:
        raise ValueError("heavy_model is given but model is 'full'; pass model='heavy' to use it")
    if model == "heavy":
        install_heavy_model(heavy_model)


def load_pose_estimator(
    static: bool = False,
    min_detection_confidence: float = 0.5,
    min_tracking_confidence: float = 0.5,
    model: str = "full",
    heavy_model: str | os.PathLike | None = None,
):
    """A MediaPipe Pose estimator; ``static`` = no tracking.

    Args:
        model: ``"full"`` (shipped in the wheel) or ``"heavy"`` (:func:`install_heavy_model`;
            ``heavy_model`` = path of a verified copy, else the module folder's). Nothing is
            downloaded: MediaPipe's own downloader is disabled while the estimator is built.

    Raises:
        ImportError: mediapipe is not installed (``pip install -e ".[video]" && lfd-install-mediapipe``:
            its declared dependencies would add jax and a second OpenCV; :mod:`lfd.cli.install_mediapipe`).
        ValueError: ``model`` not in :data:`MODELS`; a heavy model file with the wrong checksum.
        FileNotFoundError: ``model="heavy"`` and no heavy model (the message says how to get it).
    """
    _check_model(model, heavy_model)
    try:
        _protobuf_compat()
        from mediapipe.python import solution_base

        solution_base.SolutionBase._modify_calculator_options = _set_calculator_options
        from mediapipe.python.solutions import pose as mp_pose
    except ImportError as exc:
        raise ImportError(_NO_MEDIAPIPE) from exc
    download = mp_pose.download_utils.download_oss_model
    mp_pose.download_utils.download_oss_model = _no_download
    try:
        with _stderr_to_logging():
            pose = mp_pose.Pose(
                static_image_mode=static,
                model_complexity=MODELS[model],
                smooth_landmarks=not static,
                enable_segmentation=False,
                min_detection_confidence=min_detection_confidence,
                min_tracking_confidence=min_tracking_confidence,
            )
            graph = getattr(pose, "_graph", None)  # SolutionBase's CalculatorGraph (MediaPipe 0.10.14)
            if graph is not None:
                graph.wait_until_idle()  # every calculator opened: the start-up lines are written
        return pose
    finally:
        mp_pose.download_utils.download_oss_model = download


def _no_download(model_path: str) -> None:
    """Stands in for MediaPipe's ``download_oss_model``: lfd never downloads at run time."""
    path = _mediapipe_root().parent / model_path
    if not path.is_file():
        raise FileNotFoundError(
            f"{path} is missing and lfd does not download models at run time; {_HOW_TO_GET}"
        )


def landmarks_of(result, size: tuple[int, int], offset=(0.0, 0.0), scale=1.0):
    """One MediaPipe result as (33, 2) px, (33,) visibility, (33, 3) world m; None when no person was found.

    ``size`` is the (width, height) px of the processed image; pixels are ``normalised * size *
    scale + offset`` (to map a resized or cropped image back to the original frame).
    """
    if result.pose_landmarks is None or result.pose_world_landmarks is None:
        return None
    w, h = size
    lm = result.pose_landmarks.landmark
    px = np.array([[p.x * w, p.y * h] for p in lm]) * scale + np.asarray(offset)
    vis = np.array([p.visibility for p in lm])
    world = np.array([[p.x, p.y, p.z] for p in result.pose_world_landmarks.landmark])
    return px, vis, world


_bundles: dict[str, bytes] = {}


def _task_bundle(model: str) -> bytes:
    """MediaPipe's pose-landmarker task bundle for ``model``, assembled in memory from the models the
    wheel ships (``pose_detection.tflite`` and ``pose_landmark_<model>.tflite``, the same networks
    the single-person solution runs): the tasks API wants both in one zip, each with its input
    normalisation written as TFLite metadata (the detector takes pixels in [-1, 1], the landmark
    model in [0, 1], as the solution's graph feeds them)."""
    if model not in _bundles:
        import io
        import zipfile

        from mediapipe.tasks.python.metadata.metadata_writers import metadata_writer

        modules = _mediapipe_root() / "modules"
        landmark = (
            heavy_model_path()
            if model == "heavy"
            else modules / "pose_landmark" / f"pose_landmark_{model}.tflite"
        )

        def with_normalisation(path: Path, mean: float, std: float) -> bytes:
            writer = metadata_writer.MetadataWriter.create(path.read_bytes())
            writer.add_general_info(path.stem, f"{path.name} from the MediaPipe wheel")
            writer.add_image_input(norm_mean=[mean], norm_std=[std])
            return writer.populate()[0]

        buffer = io.BytesIO()
        with zipfile.ZipFile(buffer, "w") as bundle:
            bundle.writestr(
                "pose_detector.tflite",
                with_normalisation(modules / "pose_detection" / "pose_detection.tflite", 127.5, 127.5),
            )
            bundle.writestr("pose_landmarks_detector.tflite", with_normalisation(landmark, 0.0, 255.0))
        _bundles[model] = buffer.getvalue()
    return _bundles[model]


def load_people_estimator(
    max_people: int = 4,
    min_detection_confidence: float = 0.5,
    min_tracking_confidence: float = 0.5,
    model: str = "full",
    heavy_model: str | os.PathLike | None = None,
):
    """A MediaPipe pose landmarker that finds up to ``max_people`` people in an image (``detect(image)``;
    :func:`people_of` reads the result). It runs in image mode: every call detects afresh, and
    :mod:`lfd.human.video.people` follows the people over time (the tasks API's video mode stops
    looking for further people once it tracks one).

    The single-person solution (:func:`load_pose_estimator`) follows the most prominent person;
    this one runs the same detector and landmark networks through MediaPipe's tasks API, which
    keeps several people. Nothing is downloaded: the task bundle is built in memory from the
    wheel's models (and the verified heavy model for ``model="heavy"``).

    Raises:
        ImportError, ValueError, FileNotFoundError: as :func:`load_pose_estimator`;
        ValueError also for ``max_people`` < 1.
    """
    _check_model(model, heavy_model)
    max_people = positive_int(max_people, "max_people")
    try:
        _protobuf_compat()
        from mediapipe.tasks.python import BaseOptions, vision
    except ImportError as exc:
        raise ImportError(_NO_MEDIAPIPE) from exc
    options = vision.PoseLandmarkerOptions(
        base_options=BaseOptions(model_asset_buffer=_task_bundle(model)),
        running_mode=vision.RunningMode.IMAGE,
        num_poses=max_people,
        min_pose_detection_confidence=min_detection_confidence,
        min_pose_presence_confidence=min_detection_confidence,
        min_tracking_confidence=min_tracking_confidence,
    )
    with _stderr_to_logging():
        return vision.PoseLandmarker.create_from_options(options)


def people_of(
    result, size: tuple[int, int], offset=(0.0, 0.0), scale=1.0
) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Every person of one pose-landmarker result as ``(px (33, 2), visibility (33,), world (33, 3) m)``,
    pixels mapped as in :func:`landmarks_of`; an empty list when nobody was found."""
    w, h = size
    out = []
    for image, world in zip(result.pose_landmarks, result.pose_world_landmarks):
        px = np.array([[p.x * w, p.y * h] for p in image]) * scale + np.asarray(offset)
        vis = np.array([p.visibility if p.visibility is not None else 0.0 for p in image])
        out.append((px, vis, np.array([[p.x, p.y, p.z] for p in world])))
    return out
