"""LeRobot v3.0 datasets: writer and export (:mod:`~lfd.interop.lerobot.writer`), reader and
datamodule (:mod:`~lfd.interop.lerobot.reader`), ``eval_info.json`` (:mod:`~lfd.interop.lerobot.report`)."""
