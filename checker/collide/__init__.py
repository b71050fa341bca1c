"""The machine's own solids checked against each other, the tool and the work along the motion
(docs/MATH.md §16): `check.check_machine`, hooked into the check by `section.machine_section`."""
