"""Where oimi's DDS traffic may go: closed by default, opened by flags or a config file.

Unless told otherwise, DDS traffic stays on this machine: the loopback interface only,
multicast off, discovery by unicast to ``localhost``, in the domain ``ROS_DOMAIN_ID``
(0 when unset). ``Network`` says where else to talk (an interface, peers, multicast,
or a whole Cyclone DDS XML file); nothing is read from ``CYCLONEDDS_URI``: the
configuration given here is the only one used. (No DDS import here, so the CLI's
flags work without the ``ros2`` extra.)
"""

from __future__ import annotations

import argparse
import importlib.util
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Final
from xml.sax.saxutils import quoteattr

import msgspec

from oimi.pipeline.errors import LocatedError

MAX_DOMAIN_ID: Final = 232
"""The largest domain id ROS 2 allows."""
MAX_PARTICIPANTS: Final = 32
"""Participant indices probed on each unicast peer (nodes per machine)."""


class NetworkError(LocatedError):
    """A DDS setting that cannot be used; placed at its source (flag, variable or file)."""


class Network(msgspec.Struct, frozen=True, kw_only=True):
    """Where oimi's DDS traffic may go. The defaults keep it on this machine."""

    domain_id: int = 0
    interface: str = "127.0.0.1"
    """The network interface, by address or name (``eth0``)."""
    peers: tuple[str, ...] = ("localhost",)
    """Hosts discovered by unicast (the robot's address)."""
    multicast: bool = False
    """Allow multicast (discovery of any host on the interface's network)."""
    config_file: Path | None = None
    """A whole Cyclone DDS XML configuration, used instead of the settings above."""

    def xml(self) -> str:
        """The Cyclone DDS configuration of these settings."""
        if self.config_file is not None:
            try:
                return self.config_file.read_text()
            except OSError as error:
                raise NetworkError(
                    f"cannot read: {error.strerror}", source=str(self.config_file)
                ) from None
        kind = "address" if self.interface[:1].isdigit() or ":" in self.interface else "name"
        peers = "".join(f"<Peer address={quoteattr(p)}/>" for p in self.peers)
        return (
            '<CycloneDDS xmlns="https://cdds.io/config"><Domain Id="any"><General>'
            f"<Interfaces><NetworkInterface {kind}={quoteattr(self.interface)}/></Interfaces>"
            f"<AllowMulticast>{'true' if self.multicast else 'false'}</AllowMulticast>"
            "</General><Discovery><ParticipantIndex>auto</ParticipantIndex>"
            f"<MaxAutoParticipantIndex>{MAX_PARTICIPANTS}</MaxAutoParticipantIndex>"
            f"<Peers>{peers}</Peers></Discovery></Domain></CycloneDDS>"
        )


def domain_id_from(environ: Mapping[str, str] = os.environ) -> int:
    """``ROS_DOMAIN_ID`` as ROS 2 reads it (0 when unset or empty)."""
    text = environ.get("ROS_DOMAIN_ID", "").strip()
    if not text:
        return 0
    if not text.isdigit() or int(text) > MAX_DOMAIN_ID:
        raise NetworkError(
            f"{text!r} is not a domain id (an integer from 0 to {MAX_DOMAIN_ID})",
            source="ROS_DOMAIN_ID",
        )
    return int(text)


def add_network_arguments(parser: argparse.ArgumentParser) -> None:
    """The DDS network flags shared by ``oimi bridge`` and ``oimi sim --ros2``."""
    group = parser.add_argument_group("DDS network (default: this machine only)")
    group.add_argument("--domain-id", type=int, help="DDS domain (default: ROS_DOMAIN_ID, else 0)")
    group.add_argument(
        "--dds-interface",
        default="127.0.0.1",
        help="network interface by address or name (default: loopback 127.0.0.1)",
    )
    group.add_argument(
        "--dds-peer",
        action="append",
        metavar="HOST",
        help="a host to discover by unicast (repeatable; default: localhost)",
    )
    group.add_argument(
        "--dds-multicast", action="store_true", help="allow multicast discovery and data"
    )
    group.add_argument(
        "--dds-config", type=Path, help="a Cyclone DDS XML file used instead of the flags above"
    )


def network_from_args(args: argparse.Namespace) -> Network:
    """The ``Network`` the flags ask for."""
    domain_id = domain_id_from() if args.domain_id is None else args.domain_id
    if not 0 <= domain_id <= MAX_DOMAIN_ID:
        raise NetworkError(
            f"{domain_id} is not a domain id (0 to {MAX_DOMAIN_ID})", source="--domain-id"
        )
    return Network(
        domain_id=domain_id,
        interface=args.dds_interface,
        peers=tuple(args.dds_peer or ("localhost",)),
        multicast=args.dds_multicast,
        config_file=args.dds_config,
    )


def missing_extra() -> str | None:
    """Why the ROS 2 edge cannot run in this environment (None when it can)."""
    for module in ("cyclonedds", "rosbags"):
        if importlib.util.find_spec(module) is None:
            return f"the {module} package is missing: pip install 'oimi[ros2]'"
    return None
