"""MPU-9150 register map (the MPU-6050's, register map rev 4.2) and scale tables.

Addresses are register numbers on the chip; ``*_LSB_PER_*`` tables are keyed by the
2-bit range code (AFS_SEL / FS_SEL) stored in ACCEL_CONFIG / GYRO_CONFIG bits 4:3.
"""

from __future__ import annotations

#: I2C addresses: AD0 low (default) and high
DEFAULT_ADDRESS = 0x68
ADDRESSES = (0x68, 0x69)

# -- registers -------------------------------------------------------------------------
SMPLRT_DIV, CONFIG, GYRO_CONFIG, ACCEL_CONFIG = 0x19, 0x1A, 0x1B, 0x1C
FIFO_EN, INT_PIN_CFG, INT_ENABLE, INT_STATUS = 0x23, 0x37, 0x38, 0x3A
ACCEL_XOUT_H, TEMP_OUT_H, GYRO_XOUT_H = 0x3B, 0x41, 0x43
DATA_LAST = 0x48  # GYRO_ZOUT_L: the data registers are ACCEL_XOUT_H..DATA_LAST, big-endian
USER_CTRL, PWR_MGMT_1, PWR_MGMT_2 = 0x6A, 0x6B, 0x6C
FIFO_COUNTH, FIFO_COUNTL, FIFO_R_W, WHO_AM_I = 0x72, 0x73, 0x74, 0x75
WHO_AM_I_VALUE = 0x68

# -- bits ------------------------------------------------------------------------------
PWR_DEVICE_RESET, PWR_SLEEP, PWR_CLKSEL_PLL_X = 0x80, 0x40, 0x01
USER_CTRL_FIFO_EN, USER_CTRL_FIFO_RESET = 0x40, 0x04
INT_DATA_RDY, INT_FIFO_OFLOW = 0x01, 0x10
INT_PIN_CFG_I2C_BYPASS_EN = 0x02
#: FIFO_EN bits: TEMP, XG, YG, ZG, ACCEL (bit 3)
FIFO_EN_TEMP, FIFO_EN_XG, FIFO_EN_YG, FIFO_EN_ZG, FIFO_EN_ACCEL = 0x80, 0x40, 0x20, 0x10, 0x08
FIFO_EN_ALL = FIFO_EN_TEMP | FIFO_EN_XG | FIFO_EN_YG | FIFO_EN_ZG | FIFO_EN_ACCEL
FIFO_SIZE = 1024  # bytes

# -- scales ----------------------------------------------------------------------------
#: full-scale range -> 2-bit range code
ACCEL_RANGES = {2: 0, 4: 1, 8: 2, 16: 3}  # g
GYRO_RANGES = {250: 0, 500: 1, 1000: 2, 2000: 3}  # deg/s
#: range code -> sensitivity
ACCEL_LSB_PER_G = {0: 16384.0, 1: 8192.0, 2: 4096.0, 3: 2048.0}  # counts/g
GYRO_LSB_PER_DPS = {0: 131.0, 1: 65.5, 2: 32.8, 3: 16.4}  # counts/(deg/s)
#: DLPF_CFG (CONFIG bits 2:0) -> accelerometer bandwidth, Hz
DLPF_BW_HZ = {0: 260.0, 1: 184.0, 2: 94.0, 3: 44.0, 4: 21.0, 5: 10.0, 6: 5.0, 7: 260.0}
#: thermometer: T [C] = raw / TEMP_LSB_PER_C + TEMP_OFFSET_C
TEMP_LSB_PER_C, TEMP_OFFSET_C = 340.0, 35.0
#: output rate with the DLPF on: SAMPLE_BASE_HZ / (1 + SMPLRT_DIV), SMPLRT_DIV 0..255
SAMPLE_BASE_HZ = 1000.0
SAMPLE_RATES_HZ = tuple(SAMPLE_BASE_HZ / (1 + n) for n in range(256))

#: the AK8975 magnetometer answers here once INT_PIN_CFG enables the bypass
AK8975_ADDRESS = 0x0C

# -- digital low-pass filter (register map rev 4.2, section 4.3, CONFIG) -------------------
#: DLPF_CFG -> (accelerometer bandwidth Hz, delay ms), (gyroscope bandwidth Hz, delay ms)
DLPF_ACCEL = {0: (260.0, 0.0), 1: (184.0, 2.0), 2: (94.0, 3.0), 3: (44.0, 4.9), 4: (21.0, 8.5), 5: (10.0, 13.8),
              6: (5.0, 19.0), 7: (260.0, 0.0)}
DLPF_GYRO = {0: (256.0, 0.98), 1: (188.0, 1.9), 2: (98.0, 2.8), 3: (42.0, 4.8), 4: (20.0, 8.3), 5: (10.0, 13.4),
             6: (5.0, 18.6), 7: (2100.0, 0.17)}

# -- self-test (register map rev 4.2, sections 4.1 and 4.4-4.5) ---------------------------------
#: SELF_TEST_X/Y/Z: bits 7:5 XA_TEST[4:2], bits 4:0 XG_TEST; SELF_TEST_A: XA[1:0] 5:4, YA[1:0] 3:2, ZA[1:0] 1:0
SELF_TEST_X, SELF_TEST_Y, SELF_TEST_Z, SELF_TEST_A = 0x0D, 0x0E, 0x0F, 0x10
#: ACCEL_CONFIG / GYRO_CONFIG bits 7:5: self-test of X, Y, Z
SELF_TEST_BITS = (0x80, 0x40, 0x20)
#: ranges the factory trim refers to: accelerometer +-8 g (code 2), gyroscope +-250 deg/s (code 0)
SELF_TEST_ACCEL_RANGE, SELF_TEST_GYRO_RANGE = 2, 0
SELF_TEST_TOLERANCE = 0.14  # |response - trim| / trim


def decode_self_test(regs) -> tuple[list[int], list[int]]:
    """(accelerometer codes XA/YA/ZA_TEST, gyroscope codes XG/YG/ZG_TEST), 5 bits each, from 0x0D..0x10."""
    x, y, z, a = (int(v) for v in regs)
    accel = [((r >> 3) & 0x1C) | ((a >> s) & 3) for r, s in ((x, 4), (y, 2), (z, 0))]
    return accel, [r & 0x1F for r in (x, y, z)]


def encode_self_test(accel_codes, gyro_codes) -> bytes:
    """The four register bytes 0x0D..0x10 holding the given 5-bit codes."""
    xyz = bytes((((int(ac) >> 2) & 7) << 5) | (int(gc) & 0x1F) for ac, gc in zip(accel_codes, gyro_codes))
    a = sum((int(ac) & 3) << s for ac, s in zip(accel_codes, (4, 2, 0)))
    return xyz + bytes([a])


def accel_factory_trim_lsb(code: int) -> float:
    """FT[Xa] = 4096 * 0.34 * (0.92/0.34)^((code - 1)/(2^5 - 2)) counts at +-8 g; 0 for code 0."""
    return 0.0 if code == 0 else 4096 * 0.34 * (0.92 / 0.34) ** ((code - 1) / 30.0)


def gyro_factory_trim_lsb(code: int, axis: int) -> float:
    """FT[Xg] = 25 * 131 * 1.046^(code - 1) counts at +-250 deg/s, negative for Y; 0 for code 0."""
    return 0.0 if code == 0 else (-1.0 if axis == 1 else 1.0) * 25 * 131 * 1.046 ** (code - 1)


# -- auxiliary I2C master (register map rev 4.2, sections 4.6-4.13, 4.19-4.21) -------------------
I2C_MST_CTRL, I2C_SLV0_ADDR, I2C_SLV0_REG, I2C_SLV0_CTRL = 0x24, 0x25, 0x26, 0x27
I2C_SLV4_CTRL, I2C_MST_STATUS = 0x34, 0x36
EXT_SENS_DATA_00, EXT_SENS_DATA_COUNT = 0x49, 24
I2C_SLV0_DO, I2C_MST_DELAY_CTRL = 0x63, 0x67
USER_CTRL_I2C_MST_EN = 0x20
I2C_SLV_READ, I2C_SLV_EN = 0x80, 0x80  # SLVx_ADDR bit 7 (1 = read), SLVx_CTRL bit 7
