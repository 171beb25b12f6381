"""Loading MediaPipe Pose 0.10.14 (BlazePose GHUM, the *full* landmark model; the model files
ship inside the wheel, nothing is downloaded) and reading its results as arrays.

MediaPipe 0.10.14's Python layer predates protobuf 5; every :func:`load_pose_estimator` call
patches it process-wide (idempotent): the removed ``GetPrototype`` calls are restored on
protobuf's symbol database and message factory, and ``SolutionBase._modify_calculator_options``
is replaced by a version that works on protobuf 4 to 7. Install with ``pip install "lfd[video]"``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["landmarks_of", "load_pose_estimator"]


def _protobuf_compat() -> None:
    """Restore the two protobuf calls MediaPipe 0.10.14's Python layer uses.

    ``GetPrototype`` was removed from the symbol database / message factory (replaced by
    ``message_factory.GetMessageClass``) and ``FieldDescriptor.label`` by ``is_repeated``;
    the solution API uses both when it sets calculator options and reads output packets.
    """
    from google.protobuf import message_factory, symbol_database

    for cls in (symbol_database.SymbolDatabase, message_factory.MessageFactory):
        if not hasattr(cls, "GetPrototype"):
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


def load_pose_estimator(
    static: bool = False, min_detection_confidence: float = 0.5, min_tracking_confidence: float = 0.5
):
    """A MediaPipe Pose estimator (full model, shipped in the wheel); ``static`` = no tracking.

    Raises:
        ImportError: mediapipe is not installed (``pip install -e ".[video]" && pip install --no-deps
            mediapipe==0.10.14``: its declared dependencies would add jax and a second OpenCV).
    """
    try:
        _protobuf_compat()
        from mediapipe.python import solution_base

        solution_base.SolutionBase._modify_calculator_options = _set_calculator_options
        from mediapipe.python.solutions import pose as mp_pose
    except ImportError as exc:
        raise ImportError(
            "the video pose estimator needs MediaPipe 0.10.14 without its declared dependencies: "
            'pip install -e ".[video]" && pip install --no-deps mediapipe==0.10.14'
        ) from exc
    return mp_pose.Pose(
        static_image_mode=static,
        model_complexity=1,
        smooth_landmarks=not static,
        enable_segmentation=False,
        min_detection_confidence=min_detection_confidence,
        min_tracking_confidence=min_tracking_confidence,
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
