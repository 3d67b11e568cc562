"""Floor 6, the rig planner: mirror layouts searched on the simulator for a subject in a room, their
predicted coverage and noise, and the files a plan folder holds (docs/DESIGN.md, "Plan folders")."""

__all__: list[str] = []
