def make_benchmark(): pass
