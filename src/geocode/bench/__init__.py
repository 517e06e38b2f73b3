"""`geocode bench <subject>`: every benchmark, one module per subject (no timings in tests).

    program   shapes/s of a program, faces, loose parts, the drop test
    dataset   export shapes/s, sketch views/s, clouds/s
    train     encoder samples/s and inference latency; one training epoch
    evaluate  rebuilt shapes/s, Chamfer time, drop-test time
    fit       the fit of `geocode reconstruct` on a run's test clouds
"""
