"""pathcheck post-processor: machine definitions, part <-> machine kinematics, G-code writer and
reader."""
