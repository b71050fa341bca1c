"""pathcheck post-processor: machines as kinematic chains, part <-> machine kinematics, G-code
writer and reader in six dialects, machine checks.

- `machine`: `Machine` (pydantic, `checker/resources/machines/*.toml`: linear axes, rotary axes
  on the table or the head, limits, wraps, TCP, setup), `load_machine(name_or_path)`;
- `kinematics`: `Chain(machine)`: forward and inverse kinematics from the chain, both 5-axis
  solutions, the choice between them and the pole report, tip path length;
- `wrap`: rotary words per wrap mode, and back;
- `dialects`: Fanuc, Haas, LinuxCNC, Sinumerik 840D, Heidenhain ISO, MillPlus as tables plus hooks;
- `post`: `PostMoves`, `moves_from_toolpath(...)`, `post(moves, machine)`, `post_toolpath(...)`;
- `writer`: program text, `write_program(text, path)` (atomic);
- `gcode_lex`, `reader`: `read_gcode(path, dialect) -> GcodeMoves` (program X Y Z and words);
- `replay`: `part_motions(moves, machine) -> PartMotions` (part frame);
- `checks`: travel, rotary limits and wraps, singular passages, axis feeds of a program;
- `describe`: the `pathcheck check-gcode` summary.
"""
