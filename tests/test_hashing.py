import numpy as np

from hexatissue._hashing import GOLDEN, mix64


def test_mix64_is_splitmix64():
    # splitmix64 seeded with 0: its n-th output is the finaliser of n * GOLDEN (published reference outputs)
    counters = (np.arange(1, 5, dtype=np.uint64) * np.uint64(GOLDEN))
    expected = [0xE220A8397B1DCDAF, 0x6E789E6AA1B965F4, 0x06C45D188009454F, 0xF88BB8A8724C81EC]
    assert mix64(counters).tolist() == expected
    assert int(mix64(np.uint64(GOLDEN))) == expected[0]  # scalars too
