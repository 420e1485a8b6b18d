"""Prints a JSON output of fleetdyn without its wall-clock times, canonically ordered.

    python3 scripts/behaviour_canon.py run_report.json|proof.json

Used by scripts/behaviour.sh: the run report loses its `elapsed_s` fields (and its drives are
sorted by id, since completion order depends on the scheduler); the proof summary loses its
per-case `seconds` and median times.
"""
import json
import sys


def strip(o, keys):
    if isinstance(o, dict):
        return {k: strip(v, keys) for k, v in o.items() if k not in keys}
    if isinstance(o, list):
        return [strip(v, keys) for v in o]
    return o


def main(path):
    doc = json.load(open(path))
    doc = strip(doc, {"elapsed_s", "seconds", "median_seconds", "median_seconds_per_drive_hour"})
    if isinstance(doc.get("drives"), list):
        doc["drives"].sort(key=lambda d: d.get("drive_id", ""))
    print(json.dumps(doc, sort_keys=True))


if __name__ == "__main__":
    main(sys.argv[1])
