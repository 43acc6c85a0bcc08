"""Playing a bag into running nodes without losing its first messages (rostests, benchmarks).

`rosbag play` publishes as soon as it starts, while the nodes under test may not have connected
to its topics yet: on a loaded machine the first frames were lost. Here the player starts paused
and resumes only once every required subscriber has an open connection to it, and once the
calling node's own subscriptions (`listening`: the outputs a test counts) are connected to their
publishers, so that the first output is not lost either.
"""
import subprocess
import time
import xmlrpc.client

import rosgraph
import rospy
from std_srvs.srv import SetBool


def wait_until(predicate, timeout, period=0.05):
    """Polls `predicate` until it holds or `timeout` s have passed; returns its last value."""
    end = time.time() + timeout
    while time.time() < end:
        if predicate():
            return True
        time.sleep(period)
    return predicate()


def publisher_connected(node, required):
    """True when `node` publishes every topic of `required` (topic -> node names) with an open
    connection to each of its nodes (a nodelet counts as its manager)."""
    try:
        uri = rosgraph.masterapi.Master('/bag_playback_check').lookupNode(node)
        _, _, connections = xmlrpc.client.ServerProxy(uri).getBusInfo('/bag_playback_check')
    except Exception:  # not registered yet
        return False
    outbound = {}
    for connection in connections:
        if connection[2] == 'o':
            outbound.setdefault(connection[4], set()).add(connection[1])
    return all(set(nodes) <= outbound.get(topic, set()) for topic, nodes in required.items())


def listening_connected(subscribers):
    """True when each rospy Subscriber of `subscribers` is connected to every publisher the
    master lists for its topic, and there is at least one."""
    try:
        publishers, _, _ = rosgraph.masterapi.Master('/bag_playback_check').getSystemState()
    except Exception:  # the master is busy: ask again
        return False
    nodes = dict((topic, len(names)) for topic, names in publishers)
    return all(0 < nodes.get(s.resolved_name, 0) <= s.get_num_connections() for s in subscribers)


def start_player(bag, name, rate, extra_args=()):
    """`rosbag play --clock` of `bag` as node `name`, started paused; its outgoing queue holds the
    whole bag, so a stalled subscriber loses nothing."""
    cmd = ['rosbag', 'play', '--clock', '--quiet', '--queue', '100000', '--pause', '--rate',
           str(rate)] + list(extra_args) + [bag, '__name:=' + name.lstrip('/')]
    return subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, universal_newlines=True)


def resume_when_connected(player_name, required, timeout=30.0, listening=()):
    """Waits until the paused player is connected as `required` says (publisher_connected: no
    message is lost at the start, however slow the machine) and the subscribers of `listening`
    to their publishers (listening_connected), then resumes it."""
    if not wait_until(lambda: publisher_connected(player_name, required), timeout, period=0.1):
        raise RuntimeError('%s: the nodes under test did not connect to the player' % player_name)
    if not wait_until(lambda: listening_connected(listening), timeout, period=0.1):
        raise RuntimeError('%s: not connected to the publishers of %s' % (
            rospy.get_name(), ', '.join(s.resolved_name for s in listening)))
    rospy.wait_for_service(player_name + '/pause_playback', timeout=10.0)
    rospy.ServiceProxy(player_name + '/pause_playback', SetBool)(False)


def play_bag(bag, name, rate, required, extra_args=(), timeout=120, listening=()):
    """Plays `bag` (start_player), resumed once connected as `required` says (topic -> node
    names) and `listening` (rospy Subscribers of the caller) to its publishers; returns when the
    player has ended."""
    player = start_player(bag, name, rate, extra_args)
    try:
        resume_when_connected(name, required, listening=listening)
        output, _ = player.communicate(timeout=timeout)
    except BaseException:
        player.kill()
        player.communicate()
        raise
    if player.returncode != 0:
        raise RuntimeError('rosbag play failed:\n' + output)
