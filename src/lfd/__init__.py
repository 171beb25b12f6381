"""lfd: learning robot manipulation skills by observation.

Sub-packages (one-way dependencies, top depends on bottom)::

    models/  LightningModules (forward MLP, inverse MLP, CNN->DMP, velocity CNN)
    data/    LightningDataModules + on-disk dataset format
    eval/    closed-loop controllers and evaluation, metrics, plots, the Sawyer protocol
    sim/     PyBullet scenes, objects, camera, scripted demonstrations, simulated arms
    rl/      PoWER, rewards, goal adaptation and refinement (numpy/torch)
    robots/  robot specs, batched FK / Jacobian / IK / RNE, reach tests, URDF writer (torch)
    dmp/     canonical system, bases, LWR fitting, batched + differentiable DMP layer
"""

__version__ = "0.1.0"
