"""The pictures of the verification: which tool draws what (images.py), matplotlib's
curves (plots.py), pyvista's field pictures (field_pictures.py, field_layout.py,
field_meshes.py), drawn in forked child processes beside the suite's work
(drawing.py). They draw a case's result (:class:`verify.harness.cases.CaseResult`)."""
