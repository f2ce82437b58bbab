"""Technicians in the lab: the people's pure model (no simulator).

:mod:`biovln_ms.people.crowd` walks a sub-env's people along shortest paths in the robot's free space
between instrument faces, stands them there, makes them wait for each other and for the robot, and cuts the
robot's moves at a person's body; :class:`~biovln_ms.people.body.PeopleStep` is what the measures read of
them after a step (:mod:`biovln_ms.metrics.people_measures`). The SAPIEN bodies and the env wiring are the
simulator layer's (:mod:`biovln_ms.tasks.people`). The guide is docs/guides/people.md.
"""
