// A ServiceStatus sample as the client API's StatusEvent: the one conversion the client
// library (its status reader) and the recorder (`tetcollide record`) share. Private: not
// installed; inline, and the library hides inlines, so it exports no symbol.
#pragma once

#include "protocol.hpp"
#include "tetcollide.h"
#include "tetcollide/client.hpp"

namespace tc::client::detail {

inline StatusEvent status_event(const tetcollide_ServiceStatus& s) {
  StatusEvent e;
  e.service_id = protocol::bounded_view(s.service_id);
  e.sequence_number = s.sequence_number;
  e.state = static_cast<StatusEvent::State>(s.state);
  e.kind = static_cast<StatusEvent::Kind>(s.kind);
  e.code = s.code;
  e.scene = protocol::bounded_view(s.scene);
  e.object = protocol::bounded_view(s.object);
  e.topology_version = s.topology_version;
  e.frame = s.frame;
  e.message = protocol::bounded_view(s.message);
  e.topology_timestamp = s.topology_timestamp;
  return e;
}

}  // namespace tc::client::detail
