"""The mechanism as data: the scene file and its validation (scene), the data model (scene_model),
the tree/loop topology and coordinates (topology), the flat parameter vector (parameters), initial
assembly (assembly) and the independent ideal-joint reference solution (ideal)."""
