"""The I2C bus budget, bit time by bit time (docs/fixture.md, "Bus budget"): a read of n bytes, a multiplexer
select, a poll of an MPU-9150's FIFO, and what one 400 kHz bus carries at 100 Hz and at 1 kHz."""

from __future__ import annotations

import pytest

from rig.config.bus_budget import (MAX_BUS_SHARE, MUX_SELECT_BITS, READ_PLANS, bus_load, byte_transfer_bits,
                                   fifo_read_bits, max_slots, poll_interval_s, read_bits, slot_bits_per_s)


def test_a_register_read_of_n_bytes_is_n_plus_3_bytes_and_four_conditions():
    # S, addr+W, reg, Sr, addr+R, n data, P, bus free: 9 bit times a byte, 1 a condition
    assert [read_bits(n) for n in (1, 2, 14, 28)] == [40, 49, 157, 283]


def test_a_multiplexer_select_is_a_send_byte_and_its_read_back():
    assert byte_transfer_bits() == 21  # S, addr, control byte, P, bus free
    assert MUX_SELECT_BITS == 42


def test_the_read_plans_are_what_the_drivers_read():
    mpu, adxl = READ_PLANS["MPU-9150"], READ_PLANS["ADXL345"]
    assert (mpu.sample_bytes, mpu.block_bytes, mpu.poll_reads, mpu.fifo_samples) == (14, 28, (1, 2), 73)
    assert (adxl.sample_bytes, adxl.block_bytes, adxl.poll_reads, adxl.fifo_samples) == (6, 6, (1, 1), 32)


def test_the_poll_interval_is_the_captures():
    from rig.execution.capture import poll_interval_s as captures

    class Chip:
        def __init__(self, fifo_samples, rate):
            self.fifo_samples, self.sample_rate_hz = fifo_samples, rate

    for model, plan in READ_PLANS.items():
        for rate in (12.5, 100.0, 200.0, 1000.0):
            assert poll_interval_s(plan, rate) == captures(Chip(plan.fifo_samples, rate)), (model, rate)


def test_fifo_samples_are_read_two_to_a_block_on_the_mpu9150():
    plan = READ_PLANS["MPU-9150"]
    assert fifo_read_bits(plan, 0) == 0
    assert fifo_read_bits(plan, 2) == 283
    assert fifo_read_bits(plan, 19) == 9 * 283 + 157


def test_one_mpu9150_slot_at_100_hz_behind_a_multiplexer():
    # a poll every 0.1825 s (73/4 samples): select 42 + INT_STATUS 40 + FIFO_COUNT 49 + 19 samples 2704 bits
    assert slot_bits_per_s("MPU-9150", 100.0, selects=1) == pytest.approx((42 + 40 + 49 + 2704) / 0.1825)
    assert slot_bits_per_s("MPU-9150", 100.0, selects=0) == pytest.approx((40 + 49 + 2704) / 0.1825)


def test_eight_mpu9150_slots_on_one_bus_at_100_hz_use_31_percent_of_400_khz():
    load = bus_load([("MPU-9150", 0x70)] * 8, 100.0)
    assert load.total_bits_per_s == pytest.approx(124274, abs=1)
    assert load.share == pytest.approx(0.3107, abs=1e-4)
    assert load.first_over(MAX_BUS_SHARE) is None


def test_eight_mpu9150_slots_at_1_khz_need_three_buses_worth_and_only_the_first_fits():
    load = bus_load([("MPU-9150", 0x70)] * 8, 1000.0)
    assert load.share == pytest.approx(3.107, abs=1e-3)
    assert load.first_over(MAX_BUS_SHARE) == 1
    assert load.first_over(1.0) == 2  # even the whole wire time carries two


def test_eight_mpu9150_slots_at_the_rapid_procedures_200_hz_use_62_percent_and_six_fit():
    # a poll every 0.09125 s (73/4 samples at 200 Hz), again 19 samples: 2835 bit times a poll
    load = bus_load([("MPU-9150", 0x70)] * 8, 200.0)
    assert load.total_bits_per_s == pytest.approx(8 * 2835 / 0.09125)
    assert round(load.total_bits_per_s / 1000) == 249 and load.share == pytest.approx(0.6214, abs=1e-4)
    assert load.first_over(MAX_BUS_SHARE) == 6 and max_slots("MPU-9150", 200.0) == 6


@pytest.mark.parametrize("model,rate,muxed,slots", [("MPU-9150", 100.0, True, 12), ("MPU-9150", 1000.0, True, 1),
                                                    ("MPU-9150", 100.0, False, 13), ("ADXL345", 100.0, True, 19),
                                                    ("ADXL345", 3200.0, True, 0)])
def test_how_many_slots_one_bus_carries(model, rate, muxed, slots):
    assert max_slots(model, rate, muxed=muxed) == slots


def test_a_second_multiplexer_on_the_bus_costs_a_deselect_per_poll():
    one = bus_load([("MPU-9150", 0x70), ("MPU-9150", 0x70)], 100.0).total_bits_per_s
    two = bus_load([("MPU-9150", 0x70), ("MPU-9150", 0x71)], 100.0).total_bits_per_s
    assert two - one == pytest.approx(2 * MUX_SELECT_BITS / 0.1825)


def test_a_slower_bus_clock_carries_a_quarter():
    fast, slow = bus_load([("MPU-9150", 0x70)], 100.0), bus_load([("MPU-9150", 0x70)], 100.0, clock_hz=100_000)
    assert slow.share == pytest.approx(4 * fast.share)
