"""Progress bars (base/progress.py): never backwards, and a throttled one still reaches the
end."""


from mirrorcore.base.progress import Ratchet


def test_a_bar_never_goes_back_and_a_throttled_one_still_reaches_the_end():
    seen, fast = [], []
    bar = Ratchet(seen.append)
    for fraction in (0.1, 0.3, 0.2, 0.3, 0.5):
        bar(fraction)
    bar.part(0.5, 1.0)(0.5)
    assert seen == [0.1, 0.3, 0.5, 0.75]
    throttled = Ratchet(fast.append, seconds=60.0)
    for fraction in (0.1, 0.2, 0.9, 1.0):
        throttled(fraction)
    assert fast == [0.1, 1.0]
