"""Parameter persistence across a restart of `kestrel run`.

Usage: gcs_params.py set NAME VALUE      set it (PARAM_VALUE echo), as run 1
       gcs_params.py expect NAME VALUE   the list and a read by name show it, as run 2
       gcs_params.py unapplied NAME VALUE   the owner never gets the set (its param_set input
                                         unrouted): the echo and a read keep the old value
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
        gcs.set_param(NAME, VALUE, "param set")
        # Nothing acknowledges the write to disk; give the link a moment before the restart.
        gcs.quiet(0.5)
    elif ACTION == "unapplied":
        old = listed[NAME]
        gcs.set_param(NAME, VALUE, "param set", expect_echo=old)
        read = gcs.read_param(NAME, "param read")
        if not math.isclose(read, old):
            raise Failed("unapplied", f"{NAME}: read {read} after an unapplied set, wanted {old}")
        gcs.results["unapplied"] = f"{NAME}={VALUE} not taken, {old} echoed and read"
    elif ACTION == "expect":
        read = gcs.read_param(NAME, "param read")
        if not (math.isclose(listed.get(NAME, math.nan), VALUE) and math.isclose(read, VALUE)):
            raise Failed("persisted", f"{NAME}: listed {listed.get(NAME)}, read {read}, wanted {VALUE}")
    else:
        raise Failed("usage", ACTION)


main(params)
