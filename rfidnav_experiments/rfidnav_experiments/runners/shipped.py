"""The nodes' parameters from their files, checked as the orchestrator checks them: as shipped
(``config/params/NODE.yaml``), for the runners that build a robot without a scenario, so that an experiment's
sensors and follower are the ones a DDS run starts, not numbers of its own; or from a file the experiment names."""

from __future__ import annotations

from pathlib import Path
from typing import Any, TypeVar

from rfidnav_common.config import node_parameter_values, parameters_from_mapping
from rfidnav_scenario.scenario import CONFIG_DIR

Parameters = TypeVar("Parameters")


def file_parameters(cls: type[Parameters], path: Path, node_name: str, prefix: str = "",
                    **injected: Any) -> Parameters:
    """``node_name``'s parameters from the parameter file ``path``, with ``injected`` values (those the
    orchestrator gives, such as ``world_file``) on top; checked as the orchestrator checks them (a bad value is
    reported against ``path`` and ``prefix``)."""
    values = {**node_parameter_values(cls, path, node_name), **injected}
    return parameters_from_mapping(cls, values, str(path), prefix)


def shipped_parameters(cls: type[Parameters], node_name: str, **injected: Any) -> Parameters:
    """``node_name``'s parameters from its shipped file, ``config/params/NODE.yaml``."""
    return file_parameters(cls, CONFIG_DIR / "params" / f"{node_name}.yaml", node_name, **injected)
