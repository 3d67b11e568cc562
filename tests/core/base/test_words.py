"""Things in words: lists and one-line sentences."""
from mirrorcore.base.words import listed, sentences


def test_lists_read_as_a_person_writes_them():
    assert listed([]) == "" and listed(["a"]) == "a" and listed(["a", "b"]) == "a and b"
    assert listed(["a", "b", "c"], "or") == "a, b or c"


def test_refusals_are_one_line_of_sentences_each_once():
    reasons = ["mirror 1: too little seen", "mirror 2: not a sphere.", "mirror 1: too little seen"]
    assert sentences(reasons) == "mirror 1: too little seen. mirror 2: not a sphere."
