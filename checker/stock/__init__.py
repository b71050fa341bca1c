"""The stock and the fixtures: the material a program removes, simulated on a dexel model of
the stock (docs/MATH.md §14), and the tool against the stock and the fixtures (crashes, holder
hits, air cuts). Part frame, mm."""
