"""units= on every reader: auto keeps each format's own unit (bit for bit), an explicit unit
scales the coordinates, a bad one names units and the accepted values; read_skeleton checks scale."""

from __future__ import annotations

import gzip
from pathlib import Path

import numpy as np
import pytest

from lfd.human import read_skeleton
from lfd.human.readers.generic_csv import read_csv
from lfd.human.readers.kinect_csv import read_kinect_csv
from lfd.human.readers.ntu import read_ntu
from lfd.human.readers.trc import read_trc
from lfd.human.readers.uiprmd import read_uiprmd

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "human"
FILES = {
    read_kinect_csv: ("kimore_ex1_excerpt.csv.gz", "m"),
    read_ntu: ("ntu_S001C001P001R001A001_excerpt.skeleton.gz", "m"),
    read_uiprmd: ("ui_prmd/Kinect/Positions/m07_s02_e01_positions.txt.gz", "cm"),
    read_trc: ("synthetic.trc", "mm"),  # the header's Units
    read_csv: ("synthetic_wide.csv", "m"),
}
TO_METRES = {"m": 1.0, "cm": 0.01, "mm": 0.001}


@pytest.mark.parametrize("reader", list(FILES), ids=lambda r: r.__name__)
def test_auto_is_the_native_unit_and_explicit_units_scale(reader):
    name, native = FILES[reader]
    path = FIXTURES / name
    default = reader(path)
    for same in (None, "auto", "AUTO", native):
        np.testing.assert_array_equal(reader(path, units=same).positions, default.positions)
    for unit, factor in TO_METRES.items():
        scaled = reader(path, units=unit)  # the reader itself only scales; read_skeleton checks
        np.testing.assert_allclose(
            scaled.positions, default.positions * factor / TO_METRES[native], rtol=1e-12
        )
    with pytest.raises(ValueError, match=r"units must be one of m, cm, mm, auto .*got 'inch'") as info:
        reader(path, units="inch")
    assert name.split("/")[-1] in str(info.value)


def test_read_skeleton_refuses_bad_units_before_reading(tmp_path):
    with pytest.raises(ValueError, match=r"^units must be one of m, cm, mm, auto .*got 'feet'$"):
        read_skeleton(tmp_path / "missing.csv", units="feet")  # the option, not the missing file


def test_trc_units_override_the_header(tmp_path):
    lines = (FIXTURES / "synthetic.trc").read_text().splitlines()
    lines[2] = lines[2].replace("\tmm\t", "\tm\t")  # the header lies: the numbers are mm
    path = tmp_path / "lying.trc"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(ValueError, match=r"lying\.trc: upper arm .*millimetres\? pass units=mm"):
        read_skeleton(path)
    fixed = read_skeleton(path, units="mm")
    np.testing.assert_array_equal(fixed.positions, read_skeleton(FIXTURES / "synthetic.trc").positions)
    lines[2] = lines[2].replace("\tm\t", "\tinch\t")  # an unknown header unit is fine when units= is given
    path.write_text("\n".join(lines) + "\n")
    np.testing.assert_array_equal(read_skeleton(path, units="mm").positions, fixed.positions)


def test_kimore_in_centimetres_is_refused_with_the_unit(tmp_path):
    rows = gzip.decompress((FIXTURES / "kimore_ex1_excerpt.csv.gz").read_bytes()).decode().splitlines()
    scaled = []
    for row in rows:
        tok = row.split(",")
        if row.strip(","):
            tok = [repr(float(v) * 100) if v.strip() and i % 4 != 3 else v for i, v in enumerate(tok)]
        scaled.append(",".join(tok))
    path = tmp_path / "kimore_cm.csv"
    path.write_text("\n".join(scaled) + "\n")
    with pytest.raises(
        ValueError, match=r"kimore_cm\.csv: upper arm 2\d\.\d+ m: .*centimetres\? pass units=cm"
    ):
        read_skeleton(path)
    np.testing.assert_allclose(
        read_skeleton(path, units="cm").positions,
        read_skeleton(FIXTURES / "kimore_ex1_excerpt.csv.gz").positions,
        rtol=1e-12,
    )
