"""Visuomotor policies for reaching: camera image + joints -> motion (thesis chapter 4).

* :mod:`lfd.visuomotor.data`: PyBullet demonstration datasets and their LightningDataModule.
* :mod:`lfd.visuomotor.policies`: CNN -> DMP, the velocity CNN, the policy factory.
* :mod:`lfd.visuomotor.eval`: closed-loop evaluation in PyBullet, metrics, plots, scenario files.

``python train.py -m experiment=quick model=cnn_dmp,velocity && python evaluate.py experiment=quick``
runs all three.
"""
