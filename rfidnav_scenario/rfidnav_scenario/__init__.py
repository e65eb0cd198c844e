"""The scenario model of rfidnav, below the orchestration: scenario files and their checks, the node registry
(the ``rfidnav.nodes`` entry points), the run metrics and the command-line value types the verbs share."""
