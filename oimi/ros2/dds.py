"""oimi's DDS participant, set up the way ROS 2 nodes on Cyclone DDS talk, on the network
that ``oimi.ros2.network.Network`` allows (this machine only by default).

QoS as ROS 2's defaults: reliable, volatile, keep last 10. ROS 2 topic ``/name`` is
the DDS topic ``rt/name``.
"""

from __future__ import annotations

from typing import Final

from cyclonedds.core import Policy, Qos
from cyclonedds.domain import Domain, DomainParticipant
from cyclonedds.internal import InvalidSample
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from oimi.ros2.network import Network, NetworkError
from oimi.ros2.topics import RosTopic

ROS_DEPTH: Final = 10


def ros_qos(depth: int = ROS_DEPTH) -> Qos:
    """ROS 2's default QoS profile (``rmw_qos_profile_default``): reliable, volatile,
    keep last ``depth`` (10)."""
    return Qos(
        Policy.Reliability.Reliable(duration(milliseconds=100)),
        Policy.Durability.Volatile,
        Policy.History.KeepLast(depth),
    )


READ_BATCH: Final = 256
"""Samples taken from a reader at a time."""
DEEP: Final = 1000
"""History depth for inputs that must not be lost between two ticks (map updates, pad
states): a tick's burst of updates exceeds ROS 2's default 10. Depth is not matched
between endpoints, so ROS 2 nodes with default QoS still connect."""


class Node:
    """One DDS participant with ROS 2 topics; ``close`` (or ``with``) releases it."""

    def __init__(self, network: Network) -> None:
        self.network = network
        try:
            self._domain = Domain(network.domain_id, network.xml())
            self.participant = DomainParticipant(network.domain_id)
        except Exception as error:  # the C library reports bad settings as DDSException
            raise NetworkError(
                f"cannot start DDS: {error}", source=str(network.config_file or "--dds-*")
            ) from None
        self._topics: dict[str, Topic] = {}

    def _topic(self, topic: RosTopic) -> Topic:
        if topic.dds_name not in self._topics:
            self._topics[topic.dds_name] = Topic(
                self.participant, topic.dds_name, topic.kind, qos=ros_qos()
            )
        return self._topics[topic.dds_name]

    def writer(self, topic: RosTopic, *, depth: int = ROS_DEPTH) -> DataWriter:
        """A writer on a ROS 2 topic, with ROS 2's default QoS (``depth``: keep last)."""
        return DataWriter(self.participant, self._topic(topic), qos=ros_qos(depth))

    def reader(self, topic: RosTopic, *, depth: int = ROS_DEPTH) -> DataReader:
        """A reader on a ROS 2 topic, with ROS 2's default QoS (``depth``: keep last)."""
        return DataReader(self.participant, self._topic(topic), qos=ros_qos(depth))

    def close(self) -> None:
        """Leave the domain (peers see the node go)."""
        self.participant.__del__()
        self._domain.__del__()

    def __enter__(self) -> Node:
        return self

    def __exit__(self, *_: object) -> None:
        self.close()


def take_all(reader: DataReader) -> list[object]:
    """Every sample waiting on ``reader``, oldest first (without the data-less notices
    DDS gives when a writer goes away)."""
    samples: list[object] = []
    while batch := reader.take(N=READ_BATCH):
        samples.extend(s for s in batch if not isinstance(s, InvalidSample))
        if len(batch) < READ_BATCH:
            break
    return samples
