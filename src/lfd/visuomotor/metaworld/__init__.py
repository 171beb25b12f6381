"""Meta-World for the visuomotor policies: expert demonstration datasets
(:mod:`~lfd.visuomotor.metaworld.demos`), their Lightning datamodule
(:mod:`~lfd.visuomotor.metaworld.datamodule`) and the closed-loop evaluator
(:mod:`~lfd.visuomotor.metaworld.evaluator`). The simulator itself is :mod:`lfd.metaworld`'s.

Names are loaded on first use (PEP 562).
"""

from typing import TYPE_CHECKING

from lfd._lazy import exports, lazy_getattr

_EXPORTS = exports(
    {
        "demos": [
            "MetaWorldData",
            "MetaWorldDataConfig",
            "generate_demonstrations",
            "load_demonstrations",
        ],
        "datamodule": ["MetaWorldDataModule"],
        "evaluator": ["MetaWorldEvaluator"],
    }
)
__getattr__, __dir__ = lazy_getattr(__name__, _EXPORTS)
__all__ = sorted(_EXPORTS)

if TYPE_CHECKING:
    from lfd.visuomotor.metaworld.datamodule import MetaWorldDataModule
    from lfd.visuomotor.metaworld.demos import (
        MetaWorldData,
        MetaWorldDataConfig,
        generate_demonstrations,
        load_demonstrations,
    )
    from lfd.visuomotor.metaworld.evaluator import MetaWorldEvaluator
