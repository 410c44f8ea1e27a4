"""Scenarios: the built-in domains' scenario generators and the domain registry.

A scenario is a world, a start state, a goal space and what the simulated human did before
speaking; generating one needs the simulated human (siftom.agents), so this layer sits above
world/, planning/ and agents/.
"""

from siftom.scenarios.base import DOMAINS, Scenario, domains, get_domain, get_scenario, scenario_ids

__all__ = ["DOMAINS", "Scenario", "domains", "get_domain", "get_scenario", "scenario_ids"]
