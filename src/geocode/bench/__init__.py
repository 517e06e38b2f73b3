"""`geocode bench <benchmark>`: every benchmark, one module per subject (no timings in tests).

    program   shapes/s of a program, faces, loose parts, the drop test
    dataset   export shapes/s, sketch views/s, clouds/s, disk; a whole domain's hours at a profile
    train     encoder samples/s and inference latency; one training epoch (`bench epoch`)
    evaluate  rebuilt shapes/s, Chamfer time, drop-test time (`bench eval`)
    fit       the fit of `geocode reconstruct` on a run's clean clouds; sketch_fit: on its sketches
    real      `geocode reconstruct` on real shapes, against its baselines; its pose under turns
              (`bench turns`)
    span      how near a program comes to real shapes, by a long fit without the network
    curve     a points-only network's and the nearest training shape's distance against training
              shapes and epochs, a power law extrapolated to the paper's size, a plot
    up        the cue weights of `--up auto`: fitted and measured on program shapes
              (`python -m geocode.bench.up fit | measure | real DIR`)

A benchmark that measures a run's shapes (fit, turns) reads the validation split unless told
otherwise: defaults are chosen there, and the tables report the test split.
"""
