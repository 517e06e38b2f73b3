"""The second half of the product: a user's meshes, scans, clouds and drawings -> a program's
parameters (`geocode reconstruct`). The first half, the workflow's steps, lives in
`geocode.steps`; the evaluation step borrows `fit` and `retrieval` from here for its "+ fit"
columns and its nearest-training-shape baseline.

- `inputs`: read meshes and clouds of any format and size into surface points.
- `pose`: the input's up axis and turn about it.
- `retrieval`: the nearest training shapes.
- `fit`: search a program's parameters and the shape's pose against a cloud.
- `linedraw`, `sketchfit`: line drawings and the search against a drawing's strokes.
- `page`: the results page and `summary.csv` of a run.
- `plan`: a run's inputs and the names of their outputs, settled before any work.
- `workers`: a folder's inputs spread over processes.
- `run`: the command itself, from files to written outputs.
"""
