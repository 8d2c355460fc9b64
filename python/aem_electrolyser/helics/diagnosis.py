"""Names in HELICS's error messages: a lost connection is reported by the id of a core
(`lost comms with 1879048194`); the federation's `current_state` (a query answered by the root
broker) tells whose core that is."""

import re


def core_owners(state):
    """{core id: 'name, name'} of the federates in each core, from a current_state answer."""
    owners = {}
    for fed in (state or {}).get("federates", []):
        a = fed["attributes"]
        owners.setdefault(a["parent"], []).append(a["name"])
    return {core: ", ".join(names) for core, names in owners.items()}


def explain(message, owners):
    """message, with the federates named where it speaks of a core by its id."""

    def name(match):
        who = owners.get(int(match.group(2)))
        return match.group(0) + (f" (the core of {who}: its process has died or lost its connection)" if who else "")

    return re.sub(r"(lost comms with|disconnecting) (\d+)", name, message)
