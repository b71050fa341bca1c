"""Developer tools: the README runner (readme.py), test setup and wheel check scripts."""
