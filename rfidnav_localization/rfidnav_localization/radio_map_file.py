"""Radio map files: WiFi fingerprints as YAML, what ``./rfidnav survey`` writes and the location server starts
from (a robot map's ``radio_map``). The database stays the server's store; the file is the reviewable,
versionable record of a survey.

Schema::

    fingerprints:
      - {position: [0.5, 0.5], rss: {"02:00:00:00:00:01": -41.2, "02:00:00:00:00:02": -63.0}, source: grid}
"""

from __future__ import annotations

from pathlib import Path

import yaml

from rfidnav_common.config import DBM, Section, check_number
from rfidnav_common.errors import ConfigError
from rfidnav_common.files import write_atomically
from rfidnav_localization.fingerprint import Fingerprint


def load_radio_map(path: Path) -> list[Fingerprint]:
    """The fingerprints of a radio map file; any problem is a ConfigError naming the file and the entry."""
    section = Section.from_file(Path(path))
    section.reject_unknown(("fingerprints", "description"))
    fingerprints = []
    for entry in section.sections("fingerprints"):
        entry.reject_unknown(("position", "rss", "source"))
        position = entry.numbers("position", length=2)
        readings = entry.section("rss")
        rss = {str(bssid): check_number(readings.raw(bssid), readings.source, readings.field(bssid),
                                        minimum=DBM.low, maximum=DBM.high) for bssid in readings.keys()}
        try:
            fingerprints.append(Fingerprint((position[0], position[1]), rss, entry.string("source", "survey")))
        except ValueError as error:          # the message names the field: "source: ..."
            raise ConfigError(entry.source, entry.prefix, str(error)) from None
    return fingerprints


def write_radio_map(path: Path, fingerprints: list[Fingerprint], description: str) -> None:
    document = {"description": description,
                "fingerprints": [{"position": [round(f.position[0], 4), round(f.position[1], 4)],
                                  "rss": {bssid: round(value, 2) for bssid, value in f.rss}, "source": f.source}
                                 for f in fingerprints]}
    write_atomically(Path(path), yaml.safe_dump(document, sort_keys=False, default_flow_style=None, width=120))
