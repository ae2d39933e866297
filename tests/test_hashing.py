import numpy as np

from numba import njit

from hexatissue._hashing import GOLDEN, mix64, mix64_word


def test_mix64_is_splitmix64():
    # splitmix64 seeded with 0: its n-th output is the finaliser of n * GOLDEN (published reference outputs)
    counters = (np.arange(1, 5, dtype=np.uint64) * np.uint64(GOLDEN))
    expected = [0xE220A8397B1DCDAF, 0x6E789E6AA1B965F4, 0x06C45D188009454F, 0xF88BB8A8724C81EC]
    assert mix64(counters).tolist() == expected
    assert int(mix64(np.uint64(GOLDEN))) == expected[0]  # scalars too


def test_mix64_word_is_mix64_in_a_kernel():
    @njit
    def words(z):
        out = np.empty_like(z)
        for k in range(len(z)):
            out[k] = mix64_word(z[k])
        return out

    z = np.random.default_rng(0).integers(0, 2**63, 1000, dtype=np.uint64) * np.uint64(2) + np.uint64(1)
    np.testing.assert_array_equal(words(z), mix64(z))
