"""The TCA9548A I2C switch: the control byte of a selection (pure), the driver against the register-level
simulator on the simulated bus (which devices answer when, byte for byte), and its faults (a stuck
control register, a switch that does not acknowledge) as one-line errors naming bus, address and channel."""

from __future__ import annotations

import numpy as np
import pytest
from smbus2 import i2c_msg

from drivers.clock import VirtualClock
from drivers.sensors import SensorError, SensorSettings, open_sensor
from drivers.sensors.regs.mpu9150 import SELF_TEST_X, WHO_AM_I
from drivers.sensors.sim.bus import SimulatedI2CBus
from drivers.sensors.sim.error_model import AccelErrorModel
from drivers.sensors.sim.mpu9150 import Mpu9150Model
from drivers.sensors.sim.physics import StaticPhysics
from drivers.sensors.sim.tca9548a import MuxFaults, Tca9548aModel
from drivers.sensors.tca9548a import MuxError, Tca9548a, channels_of, control_byte

# -- the control byte (pure) ------------------------------------------------------------------------


@pytest.mark.parametrize("channels,byte", [(None, 0x00), ((), 0x00), (0, 0x01), (3, 0x08), (7, 0x80),
                                           ((0, 7), 0x81), ((2, 5, 0), 0x25), (range(8), 0xFF)])
def test_a_selection_is_one_bit_per_channel(channels, byte):
    assert control_byte(channels) == byte


def test_every_control_byte_names_its_channels_and_back():
    for byte in range(256):
        assert control_byte(channels_of(byte)) == byte
    assert channels_of(0xA5) == (0, 2, 5, 7)


@pytest.mark.parametrize("channel", [8, -1, True, 2.0, "1"])
def test_a_channel_beyond_the_switch_is_refused(channel):
    with pytest.raises(ValueError, match="is not 0..7"):
        control_byte(channel)


# -- the driver on the simulated switch -----------------------------------------------------------


class Tap:
    """The simulated bus, with every transfer written down (method, address, arguments)."""

    def __init__(self, bus):
        self._bus, self.log = bus, []

    def __getattr__(self, name):
        method = getattr(self._bus, name)

        def call(*args):
            self.log.append((name, *args))
            return method(*args)
        return call if callable(method) else method


def _rig(faults=None, address=0x70, clock=None):
    """A bus with a switch at ``address`` and an MPU-9150 at 0x68 on channels 2 and 5 (different chips:
    seeds 1 and 2; the chip on channel 5 feels the opposite force)."""
    clock = clock or VirtualClock()
    bus = SimulatedI2CBus(1)
    mux = Tca9548aModel(clock=clock, faults=faults).attach(bus, address)
    errors = AccelErrorModel(noise_density_g_per_rthz=[0.0] * 3)
    chips = {2: Mpu9150Model(StaticPhysics((0.0, 0.0, 1.0)), errors, clock=clock, seed=1),
             5: Mpu9150Model(StaticPhysics((0.0, 0.0, -1.0)), errors, clock=clock, seed=2)}
    for ch, chip in chips.items():
        chip.attach(mux.channel(ch), 0x68)
    return bus, mux, chips, clock


def test_select_writes_the_control_byte_and_reads_it_back():
    bus, mux, _, _ = _rig()
    tap = Tap(bus)
    Tca9548a(tap, 0x70).select(5)
    assert tap.log == [("write_byte", 0x70, 0x20), ("read_byte", 0x70)]
    assert mux.control == 0x20 and mux.connected() == (5,)
    Tca9548a(tap, 0x70).disable()
    assert tap.log[2:] == [("write_byte", 0x70, 0x00), ("read_byte", 0x70)] and mux.control == 0x00


def test_the_switch_starts_with_no_channel_connected():
    bus, _, _, _ = _rig()
    assert Tca9548a(bus).selected() == ()
    with pytest.raises(OSError):
        bus.read_byte_data(0x68, WHO_AM_I)


def test_a_device_behind_a_channel_answers_only_while_its_channel_is_selected():
    bus, _, _, _ = _rig()
    mux = Tca9548a(bus)
    sensor = open_sensor("MPU-9150", bus, 0x68)
    for ch in (2, 5):
        mux.select(ch)
        assert sensor.identify().identity_value == 0x68
    for ch in (None, 0, 3, 7):
        mux.select(ch)
        with pytest.raises(SensorError, match="MPU-9150 at 0x68: no answer on the I2C bus"):
            sensor.identify()


def test_a_device_on_the_bus_itself_answers_whatever_is_selected():
    bus, _, _, clock = _rig()
    Mpu9150Model(StaticPhysics((0.0, 0.0, 1.0)), AccelErrorModel(), clock=clock, seed=3).attach(bus, 0x69)
    mux = Tca9548a(bus)
    for ch in (None, 0, 2):
        mux.select(ch)
        assert bus.read_byte_data(0x69, WHO_AM_I) == 0x68


def test_two_chips_at_one_address_on_connected_channels_answer_together_as_a_wired_and():
    bus, _, chips, _ = _rig()
    mux = Tca9548a(bus)
    trims = {}
    for ch in (2, 5):
        mux.select(ch)
        trims[ch] = bus.read_i2c_block_data(0x68, SELF_TEST_X, 4)
    assert trims[2] != trims[5]  # two chips, two factory trims
    mux.select((2, 5))
    assert bus.read_i2c_block_data(0x68, SELF_TEST_X, 4) == [a & b for a, b in zip(trims[2], trims[5])]


def test_each_slot_is_captured_from_its_own_chip_through_the_switch():
    bus, _, _, clock = _rig()
    mux = Tca9548a(bus)
    sensors = {}
    for ch in (2, 5):
        mux.select(ch)
        sensors[ch] = open_sensor("MPU-9150", bus, 0x68, clock=clock)
        sensors[ch].configure(SensorSettings(accel_range_g=4, sample_rate_hz=100))
        sensors[ch].start()
    blocks = {2: [], 5: []}
    for _ in range(10):
        clock.sleep(0.1)
        for ch in (2, 5):
            mux.select(ch)
            blocks[ch].append(sensors[ch].read())
    for ch, sign in ((2, 1), (5, -1)):
        a = np.concatenate([b.accel_counts for b in blocks[ch]])
        assert len(a) == 100 and sensors[ch].stats.dropped == 0
        assert np.mean(a[:, 2]) == pytest.approx(sign * 8192, rel=0.05)


def test_the_switch_keeps_the_last_byte_of_a_longer_write_and_takes_a_combined_transfer():
    bus, mux, _, _ = _rig()
    bus.write_byte_data(0x70, 0x01, 0x04)  # TI SCPS207: several bytes received, the last one is kept
    assert mux.control == 0x04
    bus.i2c_rdwr(i2c_msg.write(0x70, [0x10]))
    assert mux.control == 0x10
    read = i2c_msg.read(0x70, 1)
    bus.i2c_rdwr(read)
    assert list(read) == [0x10]


# -- addresses and faults -----------------------------------------------------------------------------


@pytest.mark.parametrize("address", [0x6F, 0x78, 0x68])
def test_a_switch_address_outside_0x70_0x77_is_refused(address):
    with pytest.raises(MuxError, match=f"address 0x{address:02x} is not one of 0x70..0x77"):
        Tca9548a(SimulatedI2CBus(1), address)


def test_a_switch_that_is_not_there_is_named_with_bus_address_and_channel():
    bus, _, _, _ = _rig(address=0x70)
    with pytest.raises(MuxError) as e:
        Tca9548a(bus, 0x71).select(3)
    assert str(e.value) == ("TCA9548A at 0x71 on bus /dev/i2c-1: no answer selecting channel 3 (No such device or "
                            "address (0x71), 4 attempts); check wiring, the A0-A2 address pins and the RESET line")


def test_a_stuck_channel_is_found_by_the_read_back():
    bus, mux, _, _ = _rig(faults=MuxFaults(stuck_channel=1))
    driver = Tca9548a(bus, bus_name="sim-fixture")
    with pytest.raises(MuxError) as e:
        driver.select(3)
    assert str(e.value) == ("TCA9548A at 0x70 on bus sim-fixture: selecting channel 3 did not take (control "
                            "register reads 0x02 = channel 1, expected 0x08)")
    driver.select(1)  # the channel it is stuck on reads back right
    mux.reset()
    assert mux.connected() == (1,)


def test_a_switch_that_stops_acknowledging_fails_the_select_after_four_attempts():
    clock = VirtualClock()
    bus, mux, _, _ = _rig(faults=MuxFaults(nack_after_s=1.0), clock=clock)
    driver = Tca9548a(bus)
    driver.select(2)
    clock.sleep(1.0)
    with pytest.raises(MuxError) as e:
        driver.select(5)
    assert str(e.value).startswith("TCA9548A at 0x70 on bus /dev/i2c-1: no answer selecting channel 5 "
                                   "(Remote I/O error, 4 attempts)")
    assert driver.stats.io_retries == 3
    # what is behind the switch keeps the last selection
    assert mux.connected() == (2,) and bus.read_byte_data(0x68, WHO_AM_I) == 0x68


def test_occasional_nacks_are_retried_and_counted():
    bus, mux, _, _ = _rig(faults=MuxFaults(nack_rate=0.2, seed=4))
    driver = Tca9548a(bus)
    for ch in range(8):
        driver.select(ch)
        assert mux.connected() == (ch,)
    assert driver.stats.io_retries > 0
