"""Parameter persistence across a restart of `kestrel run`.

Usage: gcs_params.py set NAME VALUE      set it (PARAM_VALUE echo), as run 1
       gcs_params.py expect NAME VALUE   the list and a read by name show it, as run 2
       gcs_params.py unapplied NAME VALUE   the owner never gets the set (its param_set input
                                         unrouted): the echo and a read keep the old value
       gcs_params.py unsaved NAME VALUE  the parameter file cannot be written: the echo and a
                                         read keep the old value, a STATUSTEXT says why
(run by tests/gcs_pymavlink.rs; see gcs_common.py for the transcript)
"""

import math
import sys

from gcs_common import Failed, main

ACTION, NAME, VALUE = sys.argv[1], sys.argv[2], float(sys.argv[3])


def params(gcs):
    gcs.identify()
    listed = gcs.fetch_params()
    gcs.results["listed"] = listed
    if ACTION == "set":
        # The echo comes once the parameter file holds the value.
        gcs.set_param(NAME, VALUE, "param set")
    elif ACTION == "unapplied":
        old = listed[NAME]
        gcs.set_param(NAME, VALUE, "param set", expect_echo=old)
        read = gcs.read_param(NAME, "param read")
        if not math.isclose(read, old):
            raise Failed("unapplied", f"{NAME}: read {read} after an unapplied set, wanted {old}")
        gcs.results["unapplied"] = f"{NAME}={VALUE} not taken, {old} echoed and read"
    elif ACTION == "unsaved":
        old = listed[NAME]
        gcs.set_param(NAME, VALUE, "param set", expect_echo=old)
        why = f"Param {NAME} not saved"
        gcs.pump(lambda m: any(t.startswith(why) for t in gcs.statustexts), 3.0, "why STATUSTEXT")
        read = gcs.read_param(NAME, "param read")
        if not math.isclose(read, old):
            raise Failed("unsaved", f"{NAME}: read {read} after an unsaved set, wanted {old}")
        text = next(t for t in gcs.statustexts if t.startswith(why))
        gcs.results["unsaved"] = f"{NAME}={VALUE} not stored: {old} echoed and read, STATUSTEXT {text!r}"
    elif ACTION == "expect":
        read = gcs.read_param(NAME, "param read")
        if not (math.isclose(listed.get(NAME, math.nan), VALUE) and math.isclose(read, VALUE)):
            raise Failed("persisted", f"{NAME}: listed {listed.get(NAME)}, read {read}, wanted {VALUE}")
    else:
        raise Failed("usage", ACTION)


main(params)
