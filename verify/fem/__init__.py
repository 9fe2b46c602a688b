"""The FEM side: a scene's blocks re-solved with finite elements (scikit-fem).

From the scene alone, never from the engine: the blocks as the FEM sees them
(geometry.py), the interfaces between them (interfaces.py), their meshes (mesh.py),
penalty contact (contact.py) and its own contact law (contact_law.py), in-situ stress
(in_situ.py), the static model and its solve (statics.py), the quantities read off a
solution (fields.py), the model in time (dynamics.py), fracture onset (fracture.py)
and a scene turned rigidly (turn.py). It imports no other part of verify.
"""
