"""The simulated DAQ's register table (``ripple_hil_drivers.simulated.register_image``)."""

from __future__ import annotations

from ripple_hil_drivers.simulated.register_image import RegisterImage


def image() -> RegisterImage:
    table = RegisterImage()
    table.define(10, [1, 2, 3])
    table.define(14, [4])
    table.define(65534, [5, 6])
    return table


def test_a_read_is_mapped_only_where_every_address_is():
    table = image()
    assert table.mapped(10, 3) and table.mapped(11, 1) and table.mapped(14, 1)
    assert not table.mapped(10, 4)          # 13 is a gap
    assert not table.mapped(9, 2) and not table.mapped(12, 3)
    assert table.mapped(65534, 2) and not table.mapped(65535, 2)   # past the last address
    assert not table.mapped(10, 0) and not table.mapped(-1, 2)


def test_words_read_back_and_a_copy_is_independent():
    table = image()
    assert table.read(10, 3).tolist() == [1, 2, 3] and table.word(65535) == 6
    other = table.copy()
    other.write(10, [7, 8])
    assert other.read(10, 3).tolist() == [7, 8, 3]
    assert table.read(10, 3).tolist() == [1, 2, 3]
    assert other.mapped(10, 3) and not other.mapped(10, 4)
