"""A force model importable by `fingertip record --force-model tests.record.models:linear`."""


def linear(counts):
    return (counts[0] * 1e-3, counts[1] * 1e-4)


not_callable = 42
