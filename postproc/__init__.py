"""pathcheck post-processor: machine definitions, part <-> machine kinematics, G-code writer and
reader.

- `machine`: `Machine` (pydantic, `checker/resources/machines/*.toml`),
  `load_machine(name_or_path)`;
- `kinematics`: part frame <-> machine X Y Z B, tip path length relative to the part;
- `wrap`: B words per rotary wrap mode, and back;
- `dialects`: Fanuc-style ISO and LinuxCNC as tables (modal groups, codes) plus hooks;
- `post`: `PostMoves`, `moves_from_toolpath(...)`, `post_program(moves, machine, ...)`;
- `writer`: program text, `write_program(text, path)` (atomic);
- `gcode_lex`, `reader`: `read_gcode(path, dialect) -> GcodeMoves` (work frame);
- `replay`: `part_motions(moves, machine) -> PartMotions` (part frame);
- `describe`: the `pathcheck check-gcode` summary.
"""
