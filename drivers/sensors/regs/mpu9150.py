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
