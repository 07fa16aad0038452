"""The link-loss failsafe on `kestrel run`: take off in GUIDED, then fall silent.

Usage: gcs_link_loss.py [land]   (run by tests/gcs_pymavlink.rs; see gcs_common.py for the transcript)

After GUIDED, arm and MAV_CMD_NAV_TAKEOFF, once the vehicle is above 8 m the ground station
stops its heartbeats (and sends nothing else) and only listens: the vehicle must say so in a
STATUSTEXT, switch to RTL (HEARTBEAT custom_mode 6, system_status CRITICAL), come home, land
and disarm on its own.

With `land`, the ground station first sets ArduCopter's FS_GCS_ENABLE as its users do: 3
(SmartRTL) must be refused (the echo keeps 1, RTL), 5 (land) taken; the link loss must then land
where the vehicle is (LAND, custom_mode 9) and never enter RTL.
"""

import sys

from gcs_common import Failed, main, mav

TAKEOFF_M = 10.0
LAND = sys.argv[1:] == ["land"]
EXPECTED_MODE = "LAND" if LAND else "RTL"


def link_loss(gcs):
    gcs.identify()
    gcs.wait_ready()
    if LAND:
        gcs.set_param("FS_GCS_ENABLE", 3.0, "SmartRTL refused", expect_echo=1.0)
        gcs.set_param("FS_GCS_ENABLE", 5.0, "land taken")
    gcs.set_mode_message("GUIDED", "guided")
    gcs.arm()
    gcs.command(mav.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, TAKEOFF_M], "takeoff")
    gcs.pump(lambda m: gcs.rel_alt_m is not None and gcs.rel_alt_m >= 8.0, 20.0, "take-off climb")
    gcs.quiet(0.3)

    gcs.heartbeats_on = False
    silent_from = gcs.last_heartbeat_sent_boot_s
    gcs.log(f"GCS falls silent: no heartbeat sent after t={silent_from:.2f}s, "
            f"at {gcs.rel_alt_m:.2f} m in {gcs.mode}")
    gcs.pump(lambda m: m.get_type() == "STATUSTEXT" and "GCS link lost" in m.text,
             10.0, "failsafe STATUSTEXT")
    failsafe_after = gcs.boot_s - silent_from
    gcs.pump(lambda m: gcs.mode == EXPECTED_MODE and gcs.system_status == "MAV_STATE_CRITICAL",
             5.0, f"{EXPECTED_MODE} in HEARTBEAT")
    gcs.log(f"failsafe {failsafe_after:.2f} s (vehicle time) after the last heartbeat")
    gcs.pump(lambda m: not gcs.armed and gcs.landed_state == "MAV_LANDED_STATE_ON_GROUND",
             40.0, "landed and disarmed")
    gcs.quiet(0.3)
    if not any("GCS heartbeat lost" in t for t in gcs.statustexts):
        raise Failed("link STATUSTEXT", gcs.statustexts)
    if LAND and "RTL" in gcs.modes_seen:
        raise Failed("FS_GCS_ENABLE 5", f"the vehicle entered RTL: {gcs.modes_seen}")
    gcs.results["link_loss"] = {
        "failsafe_after_s": round(failsafe_after, 2),
        "modes": gcs.modes_seen,
        "statustext": gcs.statustexts,
        "landed_alt_m": gcs.rel_alt_m,
    }


main(link_loss)
