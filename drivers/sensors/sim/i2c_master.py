"""The MPU-9150's auxiliary I2C master (register map rev 4.2, sections 4.6-4.13, 4.19-4.21, 4.24).

With USER_CTRL.I2C_MST_EN set, the master runs one cycle per output sample, at the sample time:
slaves 0..3 in order, each enabled by I2C_SLVx_CTRL bit 7; I2C_SLVx_ADDR bit 7 = 1 reads
I2C_SLVx_CTRL.LEN bytes from register I2C_SLVx_REG into EXT_SENS_DATA_00.. (placed in slave order,
each read slave taking LEN bytes), = 0 writes I2C_SLVx_DO to I2C_SLVx_REG. A slave whose bit in
I2C_MST_DELAY_CTRL is set runs only every (1 + I2C_SLV4_CTRL.I2C_MST_DLY) samples. A slave that does
not answer sets its NACK bit in I2C_MST_STATUS. Not modelled: I2C_MST_CTRL's clock and WAIT_FOR_ES
(the bytes are ready at the sample time), BYTE_SW / REG_DIS / GRP, slave 4, slave data in the FIFO.
The AK8975 sees the master's transfers at the sample times, so its single-measurement timing holds.
"""

from __future__ import annotations

from drivers.sensors.regs.mpu9150 import (EXT_SENS_DATA_00, EXT_SENS_DATA_COUNT, I2C_MST_DELAY_CTRL, I2C_MST_STATUS,
                                          I2C_SLV0_ADDR, I2C_SLV0_DO, I2C_SLV4_CTRL, I2C_SLV_EN, I2C_SLV_READ)


class AuxI2CMaster:
    """Runs the master's slave transfers against the devices on the auxiliary bus."""

    def __init__(self, regs_owner, devices: dict) -> None:
        self.owner = regs_owner  # has .regs (bytearray of the MPU's registers)
        self.devices = devices  # address -> I2CDevice (with read/write_registers(..., at=t))

    def _slaves(self):
        regs = self.owner.regs
        offset = 0
        for n in range(4):
            addr, reg, ctrl = regs[I2C_SLV0_ADDR + 3 * n:I2C_SLV0_ADDR + 3 * n + 3]
            if not ctrl & I2C_SLV_EN:
                continue
            length = ctrl & 0x0F if addr & I2C_SLV_READ else 0
            yield n, addr, reg, length, offset
            offset += length

    def run(self, sample_index: int, t_s: float) -> None:
        """One master cycle at sample ``sample_index`` (time ``t_s``, clock seconds)."""
        regs = self.owner.regs
        every = 1 + (regs[I2C_SLV4_CTRL] & 0x1F)
        for n, addr, reg, length, offset in self._slaves():
            if regs[I2C_MST_DELAY_CTRL] & (1 << n) and sample_index % every:
                continue
            dev = self.devices.get(addr & 0x7F)
            if dev is None:
                regs[I2C_MST_STATUS] |= 1 << n  # I2C_SLVn_NACK
                continue
            if addr & I2C_SLV_READ:
                length = min(length, EXT_SENS_DATA_COUNT - offset)
                if length > 0:
                    data = dev.read_registers(reg, length, at=t_s)
                    regs[EXT_SENS_DATA_00 + offset:EXT_SENS_DATA_00 + offset + length] = data
            else:
                dev.write_registers(reg, bytes([regs[I2C_SLV0_DO + n]]), at=t_s)
