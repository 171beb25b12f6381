"""Reaching driven by learned forward and inverse models of the Sawyer (thesis chapter 5).

A forward model (joints -> tool position) and one inverse model per task (goal -> joint
trajectory) are trained together (:class:`SawyerModels`, ``python train.py
experiment=sawyer_models``); the protocol (:class:`~lfd.model_reaching.protocol.SawyerProtocol`,
``python evaluate.py eval=sawyer``) reaches new goals with them and refines the reach with
PoWER. Modules: :mod:`~lfd.model_reaching.demonstrations` (demonstrations, inverse-model
data), :mod:`~lfd.model_reaching.data` (forward-model samples, datamodules),
:mod:`~lfd.model_reaching.forward`, :mod:`~lfd.model_reaching.inverse`,
:mod:`~lfd.model_reaching.models`, :mod:`~lfd.model_reaching.protocol`,
:mod:`~lfd.model_reaching.report`.
"""

from lfd.model_reaching.models import SawyerModels, load_sawyer_models

__all__ = ["SawyerModels", "load_sawyer_models"]
