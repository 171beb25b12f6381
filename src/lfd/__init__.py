"""lfd: learning robot manipulation skills by observation.

Sub-packages (one-way dependencies, top depends on bottom)::

    models/  LightningModules (forward MLP, inverse MLP, CNN->DMP, velocity CNN)
    data/    LightningDataModules + on-disk dataset format
    eval/    closed-loop evaluation, metrics, plots
    sim/     PyBullet scenes, objects, camera, scripted demonstrations
    rl/      PoWER and rewards (numpy/torch)
    robots/  robot specs, batched FK / Jacobian / IK / RNE, URDF writer (torch)
    dmp/     canonical system, bases, LWR fitting, batched + differentiable DMP layer
"""

__version__ = "0.1.0"
