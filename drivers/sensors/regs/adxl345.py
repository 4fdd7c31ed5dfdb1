"""ADXL345 register map (datasheet rev. E) and scale tables. The chip has no thermometer."""

from __future__ import annotations

#: I2C addresses: ALT ADDRESS low (default) and high
DEFAULT_ADDRESS = 0x53
ADDRESSES = (0x53, 0x1D)

# -- registers -------------------------------------------------------------------------
DEVID, OFSX, BW_RATE, POWER_CTL, INT_SOURCE, DATA_FORMAT = 0x00, 0x1E, 0x2C, 0x2D, 0x30, 0x31
DATAX0, FIFO_CTL, FIFO_STATUS = 0x32, 0x38, 0x39
DEVID_VALUE = 0xE5
REGISTER_COUNT = 0x3A

# -- bits ------------------------------------------------------------------------------
POWER_CTL_MEASURE = 0x08
DATA_FORMAT_SELF_TEST, DATA_FORMAT_FULL_RES, DATA_FORMAT_JUSTIFY = 0x80, 0x08, 0x04
INT_DATA_READY, INT_OVERRUN = 0x80, 0x01
FIFO_MODE_BYPASS, FIFO_MODE_FIFO, FIFO_MODE_STREAM = 0, 1, 2  # FIFO_CTL bits 7:6
FIFO_DEPTH = 32  # samples

# -- scales ----------------------------------------------------------------------------
#: full-scale range (g) -> DATA_FORMAT range bits 1:0
RANGE_BITS = {2: 0, 4: 1, 8: 2, 16: 3}
#: output rate (Hz) -> BW_RATE code: rate = 3200 / 2^(15 - code), 6.25 .. 3200 Hz
RATE_CODES = {3200 / 2 ** (15 - c): c for c in range(6, 16)}
SAMPLE_RATES_HZ = tuple(sorted(RATE_CODES))
FULL_RES_LSB_PER_G = 256.0  # 3.9 mg/LSB at every range
OFS_G_PER_LSB = 0.0156  # OFSX..OFSZ offset registers, g per LSB


def rate_hz(bw_rate: int) -> float:
    """Output rate, Hz, of a BW_RATE register value."""
    return 3200.0 / 2 ** (15 - (bw_rate & 0x0F))


def range_g(data_format: int) -> int:
    """Full-scale range, g (+-2/4/8/16), of a DATA_FORMAT register value."""
    return 2 << (data_format & 3)


def output_bits(data_format: int) -> int:
    """Bits of the output word: 10 in 10-bit mode; 10/11/12/13 at +-2/4/8/16 g with FULL_RES."""
    return 10 + (data_format & 3) if data_format & DATA_FORMAT_FULL_RES else 10


def lsb_per_g(data_format: int) -> float:
    """Sensitivity, counts/g, of a DATA_FORMAT register value, right-justified (JUSTIFY = 0).

    Datasheet rev. E, Table 1: FULL_RES = 1: 256 LSB/g (3.9 mg/LSB) at every range; FULL_RES = 0
    (10-bit, the power-up default): 256/128/64/32 LSB/g at +-2/4/8/16 g.
    """
    if data_format & DATA_FORMAT_FULL_RES:
        return FULL_RES_LSB_PER_G
    return 256.0 / (2 ** (data_format & 3))


def justify_shift(data_format: int) -> int:
    """Left shift of the output word: 0 right-justified; with JUSTIFY the MSB sits at bit 15."""
    return 16 - output_bits(data_format) if data_format & DATA_FORMAT_JUSTIFY else 0
