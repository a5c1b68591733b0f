"""Which topics the recorder records: listed ``topics``, a ``regex``, and where everything is: the transform
tree and the run's map datum (so every bag says where its ``map`` lies on the earth)."""

from __future__ import annotations

import re
from collections.abc import Sequence

from track_msgs_py.topics import MAP_DATUM, READY, TF, TF_STATIC
from track_nodes.base.params import ParameterError

EXCLUDED_BY_DEFAULT = ('/rosout', '/parameter_events', READY)  # READY: the nodes' start-up announcements
TF_TOPICS = (TF, TF_STATIC, MAP_DATUM)  # recorded whatever the filter, unless tf is false


class TopicFilter:
    """``topics`` (names, '/' added), every topic matching ``regex`` (all if neither), /tf, /tf_static and
    /map_datum if ``tf``."""

    def __init__(self, topics: Sequence[str], regex: str, tf: bool) -> None:
        self.explicit = {t if t.startswith('/') else '/' + t for t in topics if t}
        try:
            self.regex = re.compile(regex) if regex else None
        except re.error as exc:
            raise ParameterError(f'parameter regex={regex!r} is not a valid regular expression: {exc}') from None
        if self.regex is None and not self.explicit:
            self.regex = re.compile('')  # everything
        self.tf = tf

    def wanted(self, topic: str) -> bool:
        if topic in self.explicit:
            return True
        if topic in TF_TOPICS:
            return self.tf
        if topic in EXCLUDED_BY_DEFAULT or self.regex is None:
            return False
        return self.regex.search(topic) is not None

    def describe(self) -> str:
        what = []
        if self.explicit:
            what.append('topics ' + ', '.join(sorted(self.explicit)))
        if self.regex is not None:
            what.append(f'topics matching {self.regex.pattern!r}' if self.regex.pattern else 'all topics')
        what.append('/tf, /tf_static and /map_datum' if self.tf else 'not /tf, /tf_static or /map_datum')
        return ' and '.join(what)
