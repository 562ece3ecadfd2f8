"""The launch-free harness itself: private contexts, message delivery, clean shutdown."""

from __future__ import annotations

from std_msgs.msg import String

from dempath.nodes.harness import RosHarness


def test_probe_round_trip(ros_harness: RosHarness) -> None:
    """A message published by the probe reaches the probe's own subscription."""
    got = ros_harness.collect(String, '/harness_check')
    pub = ros_harness.publisher(String, '/harness_check')
    assert ros_harness.wait_for_subscribers(pub), 'subscription never matched'
    pub.publish(String(data='hello'))
    assert ros_harness.spin_until(lambda: len(got) == 1, timeout_s=5.0), 'message not delivered'
    assert got[0].data == 'hello'


def test_two_harnesses_do_not_see_each_other() -> None:
    """Harnesses on different domains never exchange messages."""
    with RosHarness() as a, RosHarness() as b:
        assert a.domain_id != b.domain_id
        got_b = b.collect(String, '/isolated')
        pub_a = a.publisher(String, '/isolated')
        a.collect(String, '/isolated')
        a.wait_for_subscribers(pub_a, 1, timeout_s=2.0)
        for _ in range(10):
            pub_a.publish(String(data='x'))
            a.spin_for(0.05)
            b.spin_for(0.05)
        assert got_b == [], 'message crossed ROS domains'
