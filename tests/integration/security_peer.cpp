// A second DDS participant for the security tests, run as its own process: Cyclone DDS
// allows one configuration per domain id and process, and these tests need participants
// with different identities (or none) on the same domain as the test's own client.
//
//   itest_security_peer client   DOMAIN CONFIG SCENE SECONDS
//     Connects libtetcollide_client with CONFIG (Options::cyclonedds_config), registers
//     the object "intruder" in SCENE and streams its states for SECONDS, then prints
//     "connected=1", "status_events=N" (ServiceStatus samples of any service),
//     "registered=0|1" (a verdict on "intruder" came) and "forces=N" (answered frames).
//     A connection error prints "connect_error=<message>" and exits 3.
//
//   itest_security_peer noforces DOMAIN CONFIG SCENE SECONDS
//     1. Client::connect with CONFIG: prints "client_error=<message>" when it throws.
//     2. A bare participant with CONFIG: prints "forces_reader=<ok|DDS error>",
//        "forces_writer=<ok|DDS error>", "status_reader=<ok|DDS error>", then waits up to
//        SECONDS for a ServiceStatus sample of a READY service and prints
//        "status_samples=N" (it stops at the first READY one).
//
// Exit code 0 unless the arguments are wrong (2) or a connection fails (3).
#include <dds/dds.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>

#include "protocol.hpp"
#include "scenes.hpp"
#include "tetcollide/client.hpp"

namespace {

using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

int run_client(std::uint32_t domain, const std::string& config, const std::string& scene,
               double seconds) {
  tc::client::Options o;
  o.domain = domain;
  o.scene = scene;
  o.cyclonedds_config = config;
  std::unique_ptr<tc::client::Client> c;
  try {
    c = tc::client::Client::connect(o);
  } catch (const std::exception& e) {
    std::printf("connect_error=%s\n", e.what());
    return 3;
  }
  std::printf("connected=1\n");
  const tc::client::Mesh mesh = tc::itest::box_mesh(2, {-0.5, -0.5, -0.5}, {0.5, 0.5, 0.5});
  c->register_object("intruder", mesh, {});
  std::size_t status_events = 0;
  std::size_t forces = 0;
  bool registered = false;
  const auto end = Clock::now() + std::chrono::duration<double>(seconds);
  for (std::int64_t f = 0; Clock::now() < end; ++f) {
    const auto p = tc::itest::translated(mesh, {0.0, 0.0, 0.001 * static_cast<double>(f % 20)});
    c->publish_states(f, {{"intruder", p}});
    if (c->wait_forces(f, 20ms)) ++forces;
    for (const auto& e : c->take_status_events()) {
      ++status_events;
      registered = registered || e.object == "intruder";
    }
  }
  std::printf("status_events=%zu\nregistered=%d\nforces=%zu\n", status_events, registered ? 1 : 0,
              forces);
  return 0;
}

std::string outcome(dds_entity_t e) {
  return e < 0 ? tc::protocol::dds_error(e) : std::string("ok");
}

int run_noforces(std::uint32_t domain, const std::string& config, const std::string& scene,
                 double seconds) {
  try {
    tc::client::Options o;
    o.domain = domain;
    o.scene = scene;
    o.cyclonedds_config = config;
    auto c = tc::client::Client::connect(o);
    std::printf("client_error=none\n");
  } catch (const std::exception& e) {
    std::printf("client_error=%s\n", e.what());
  }
  using tc::protocol::Topic;
  const dds_entity_t dom = dds_create_domain(domain, config.c_str());
  if (dom < 0) {
    std::printf("connect_error=dds_create_domain: %s\n", tc::protocol::dds_error(dom).c_str());
    return 3;
  }
  const dds_entity_t pp = dds_create_participant(domain, nullptr, nullptr);
  if (pp < 0) {
    std::printf("connect_error=dds_create_participant: %s\n", tc::protocol::dds_error(pp).c_str());
    dds_delete(dom);
    return 3;
  }
  const auto topic = [&](Topic t) {
    const auto qos = tc::protocol::topic_qos(t);
    return dds_create_topic(pp, tc::protocol::topic_descriptor(t), tc::protocol::topic_name(t),
                            qos.get(), nullptr);
  };
  const auto endpoint = [&](Topic t, bool read) -> dds_entity_t {
    const dds_entity_t tp = topic(t);
    if (tp < 0) return tp;
    const auto qos = tc::protocol::topic_qos(t);
    return read ? dds_create_reader(pp, tp, qos.get(), nullptr)
                : dds_create_writer(pp, tp, qos.get(), nullptr);
  };
  std::printf("forces_reader=%s\n", outcome(endpoint(Topic::kForces, true)).c_str());
  std::printf("forces_writer=%s\n", outcome(endpoint(Topic::kForces, false)).c_str());
  const dds_entity_t status = endpoint(Topic::kStatus, true);
  std::printf("status_reader=%s\n", outcome(status).c_str());
  std::size_t samples = 0;
  bool ready = false;
  const auto end = Clock::now() + std::chrono::duration<double>(seconds);
  while (status > 0 && !ready && Clock::now() < end) {
    void* buf[16] = {};
    dds_sample_info_t info[16];
    const dds_return_t n = dds_take(status, buf, info, 16, 16);
    for (dds_return_t i = 0; i < n; ++i) {
      if (!info[i].valid_data) continue;
      ++samples;
      ready = ready ||
              static_cast<const tetcollide_ServiceStatus*>(buf[i])->state == tetcollide_STATE_READY;
    }
    if (n > 0) dds_return_loan(status, buf, n);
    if (!ready) std::this_thread::sleep_for(10ms);
  }
  std::printf("status_samples=%zu\n", samples);
  dds_delete(pp);
  dds_delete(dom);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 6) {
    std::fprintf(stderr, "usage: %s client|noforces DOMAIN CONFIG SCENE SECONDS\n", argv[0]);
    return 2;
  }
  const std::string mode = argv[1];
  const auto domain = static_cast<std::uint32_t>(std::strtoul(argv[2], nullptr, 10));
  const double seconds = std::strtod(argv[5], nullptr);
  int rc = 2;
  if (mode == "client") rc = run_client(domain, argv[3], argv[4], seconds);
  if (mode == "noforces") rc = run_noforces(domain, argv[3], argv[4], seconds);
  std::fflush(stdout);
  return rc;
}
