"""The shipped udev rule (rigs/udev/99-standa-8smc.rules, docs/hardware.md) matches the controllers ``rig ports``
probes and makes the port names the template rig file uses."""

from __future__ import annotations

import re

import yaml

from rig.devices.ports import STANDA_VID_PID

from conftest import RIGS

RULE = RIGS / "udev" / "99-standa-8smc.rules"


def _rules() -> list[str]:
    return [ln for ln in RULE.read_text().splitlines() if ln.strip() and not ln.lstrip().startswith("#")]


def test_every_rule_matches_the_standa_usb_ids_rig_ports_probes():
    vendor, product = ("%04x" % n for n in STANDA_VID_PID)
    rules = _rules()
    assert rules
    for rule in rules:
        assert f'ATTRS{{idVendor}}=="{vendor}"' in rule and f'ATTRS{{idProduct}}=="{product}"' in rule, rule
        assert 'ENV{ID_MM_DEVICE_IGNORE}="1"' in rule  # ModemManager keeps off the controllers


def test_the_serial_port_gets_the_ximc_link_the_template_rig_file_names_and_the_dialout_group():
    (tty,) = [r for r in _rules() if 'SUBSYSTEM=="tty"' in r]
    assert 'SYMLINK+="ximc/$attr{serial}"' in tty and 'GROUP="dialout"' in tty and 'MODE="0660"' in tty
    axes = yaml.safe_load((RIGS / "example_hardware.yaml").read_text())["turntable"]["axes"]
    for name, axis in axes.items():  # the USB serial attribute is the controller's serial in 8 hex digits
        assert axis["port"] == f"/dev/ximc/{axis['serial']:08X}", name


def test_the_rule_says_how_to_install_it_and_where_its_ids_come_from():
    text = RULE.read_text()
    assert "sudo install -m 0644 rigs/udev/99-standa-8smc.rules /etc/udev/rules.d/" in text
    assert re.search(r"debian/libximc7\.udev", text) and "udevadm control --reload-rules" in text
