"""The interactive 3-D view of a checked job: one self-contained offline HTML page (three.js
inlined) showing the part, the tool path coloured by verdict, the findings with the real tool at
their pose, the tool axes of multi-axis jobs and, when given, the stock after each operation and
the fixtures. `checker.view.scene.build_view` makes the scene, `checker.view.viewer_page.write_view`
the page."""
