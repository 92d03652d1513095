"""Unit test (mocked client): a Modbus answer with fewer registers than asked is a typed error."""

import pytest

from ripple_hil_drivers.errors import ProtocolError
from ripple_hil_drivers.modbus_daq import ModbusDaq, ModbusTcpSettings


class ShortAnswer:
    def __init__(self, count):
        self.registers = [0] * (count - 1)

    def isError(self):  # noqa: N802 - pymodbus API
        return False


class ShortClient:
    def read_input_registers(self, address, *, count, device_id):
        return ShortAnswer(count)

    read_holding_registers = read_input_registers


def test_short_register_answer_names_the_daq_and_the_step():
    daq = ModbusDaq(ModbusTcpSettings("127.0.0.1", 1), instrument_name="daq")
    daq._client = ShortClient()
    with pytest.raises(ProtocolError, match=r"daq: read model.*asked for \d+ registers, got"):
        daq.identity()
