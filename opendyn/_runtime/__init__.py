"""Private runtime plumbing under every layer: the kernel cache and jit options, the compile
notice, kernel status codes, array helpers, batches over the cores, signals, atomic files."""
