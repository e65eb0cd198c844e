"""The nodes' parameters as shipped (``config/params/NODE.yaml``), for the runners that build a robot without a
scenario: so that an experiment's sensors and follower are the ones a DDS run starts, not numbers of its own."""

from __future__ import annotations

from typing import Any, TypeVar

from rfidnav_bringup.scenario import CONFIG_DIR
from rfidnav_common.config import node_parameter_values, parameters_from_mapping

Parameters = TypeVar("Parameters")


def shipped_parameters(cls: type[Parameters], node_name: str, **injected: Any) -> Parameters:
    """``node_name``'s parameters from its shipped file, with ``injected`` values (those the orchestrator gives,
    such as ``world_file``) on top; checked as the orchestrator checks them."""
    path = CONFIG_DIR / "params" / f"{node_name}.yaml"
    values = {**node_parameter_values(cls, path, node_name), **injected}
    return parameters_from_mapping(cls, values, str(path))
