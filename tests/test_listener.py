"""The listener behind ``siftom listen`` and the ROS bridge keeps the question it asked."""

from __future__ import annotations

from siftom.listener import HomeListener, load_home


def test_the_listener_takes_the_reply_to_its_question():
    home = HomeListener(load_home("kitchen-cereal-v0"))
    first = home.answer_text("pass me the silver").to_json()
    assert first["action"] == "ask" and "cereal" in first["question"] and "_pending" not in first
    assert home.pending is not None
    assert home.answer_text("thanks").to_json()["action"] == "none" and home.pending is not None
    reply = home.answer_text(first["decision"]["answers"][0]).to_json()  # "yes", "the cereal": the first option
    assert reply["action"] == "act" and reply["command"] == first["decision"]["options"][0] == "fetch(cereal)"
    assert reply["reply_to"] == first["question"] and home.pending is None
