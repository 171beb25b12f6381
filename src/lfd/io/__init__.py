"""File I/O owned in one place: atomic writes, deterministic npz bytes and checksums
(:mod:`lfd.io.files`), and MP4 video encoding and decoding (:mod:`lfd.io.video`).

Every file lfd writes goes through :func:`lfd.io.files.write_bytes_atomic` (or a helper built
on it), so a reader sees the old file, the complete new one, or nothing.
"""
