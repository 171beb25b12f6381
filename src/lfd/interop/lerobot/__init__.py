"""LeRobot v3.0 datasets, one concept per module: file layout and indices
(:mod:`~lfd.interop.lerobot.paths`), feature statistics (:mod:`~lfd.interop.lerobot.stats`),
JSON / parquet files (:mod:`~lfd.interop.lerobot.io`), the writer with file rollover
(:mod:`~lfd.interop.lerobot.writer`), an lfd dataset as LeRobot (:mod:`~lfd.interop.lerobot.export`),
the reader (:mod:`~lfd.interop.lerobot.reader`), the training datamodule
(:mod:`~lfd.interop.lerobot.datamodule`) and ``eval_info.json`` (:mod:`~lfd.interop.lerobot.report`)."""
