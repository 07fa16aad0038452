"""MAVLink 2 signing on `kestrel run`: only a client holding the key can command the vehicle.

Usage: gcs_signing.py KEY_HEX   (run by tests/gcs_pymavlink.rs; see gcs_common.py for the transcript)

On one socket: (1) unsigned, then (2) signed with a wrong key, GUIDED and ARM get no answer and
the vehicle stays disarmed; (3) signed with the right key, the vehicle's own signed frames
verify, and GUIDED, ARM and DISARM are ACKed ACCEPTED.
"""

import os
import sys

os.environ["MAVLINK20"] = "1"  # signing is MAVLink 2; pymavlink must not start in MAVLink 1

from gcs_common import ACM_MODES, VEHICLE, Failed, main, mav  # noqa: E402

KEY = bytes.fromhex(sys.argv[1])
WRONG_KEY = bytes(b ^ 0xFF for b in KEY)


def refused(gcs, label):
    """LOITER and ARM sent now must go unanswered, and the vehicle must stay disarmed in the mode
    it booted in (GUIDED: no radio)."""
    gcs.log(f"-> SET_MODE LOITER and COMMAND_LONG ARM, {label}")
    gcs.conn.mav.set_mode_send(VEHICLE[0], mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, ACM_MODES["LOITER"])
    gcs.conn.mav.command_long_send(*VEHICLE, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    try:
        ack = gcs.pump(lambda m: m.get_type() == "COMMAND_ACK", 1.5, "no ack")
        raise Failed(label, f"answered: {ack}")
    except Failed as e:
        if e.step != "no ack":
            raise
    gcs.log(f"no COMMAND_ACK within 1.5 s ({label})")


def signing(gcs):
    gcs.identify()
    signed = gcs.conn.mav.signing.sig_count
    if signed == 0:
        raise Failed("identify", "the vehicle's frames are not signed")
    gcs.log(f"the vehicle's frames are signed ({signed} so far; no key here yet, so unchecked)")

    gcs.wait_ready()
    refused(gcs, "unsigned")
    gcs.conn.setup_signing(WRONG_KEY, sign_outgoing=True)
    refused(gcs, "signed with a wrong key")
    if gcs.armed or gcs.mode != "GUIDED":
        raise Failed("refused", f"the vehicle obeyed: armed={gcs.armed} mode={gcs.mode}")

    gcs.conn.setup_signing(KEY, sign_outgoing=True)
    gcs.log("signing with the vehicle's key")
    # With the key set, pymavlink drops frames whose signature does not verify: hearing the
    # vehicle now proves its signatures are good.
    gcs.wait_type("HEARTBEAT", 3.0, "signed heartbeat", lambda m: m.get_signed())
    gcs.set_mode_message("GUIDED", "signed guided")
    gcs.arm("signed arm")
    gcs.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, [0], "signed disarm")
    gcs.wait_type("HEARTBEAT", 3.0, "signed disarm",
                  lambda m: not m.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED)
    gcs.results["signing"] = {
        "unsigned": "refused", "wrong_key": "refused", "signed": "GUIDED, ARM, DISARM accepted"}


main(signing)
