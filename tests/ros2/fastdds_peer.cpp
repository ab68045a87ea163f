// A ROS 2 peer written against eProsima Fast DDS only (the 2.x C++ API, as Debian's
// libfastrtps-dev ships it; no ROS, no generated code): the node's topics with their `rt/`
// prefixes, ROS 2's DDS type names and the QoS stock ROS 2 tools and ros2_control's topic
// bridges use. Its CDR (XCDR1) encoders are written here from the .msg definitions,
// independently of the Rust crate under test.
//
// Driven by tests/ros2/test_fastdds.py through a line protocol, one request per line on
// standard input, one answer line on standard output:
//
//   state                       -> "state none" | "state <taken> <sec> <nanosec> <n> <names...>
//                                  <positions...> <velocities...> <efforts...>" (the newest
//                                  joint_states sample; <taken>: samples taken by this request)
//   cmd <n> <names...> <np> <p...> <nv> <v...> <ne> <e...>
//                               -> "ok": one sensor_msgs/JointState on joint_commands
//   enable <0|1>                -> "ok": one std_msgs/Bool on enable
//   ack <timeout_ms>            -> "ack ok <us>" | "ack timeout <us>": waits until every matched
//                                  reader acknowledged the last sample written; <us> is the
//                                  time from that write to the acknowledgement
//   matched                     -> "matched <commands> <enable> <joint_states>": the matched
//                                  readers of the two writers and writers of the reader
//   quit
//
// and, whenever it happens, one event line:
//
//   participant <discovered|removed|dropped|changed> <monotonic seconds>
//
// `removed` is a participant that announced its departure (a disposal Fast DDS understood),
// `dropped` one whose lease ran out. Times are CLOCK_MONOTONIC, Python's time.monotonic().
//
// Usage: fastdds_peer <domain> <namespace> <writer heartbeat period, ms> <writer history depth>
#include <fastcdr/Cdr.h>
#include <fastcdr/FastBuffer.h>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/domain/DomainParticipantListener.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/TopicDataType.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>
#include <fastrtps/rtps/common/SerializedPayload.h>

#include <time.h>

#include <cstdint>
#include <cstdio>
#include <iostream>
#include <mutex>
#include <sstream>
#include <string>
#include <vector>

using namespace eprosima::fastdds::dds;
using eprosima::fastcdr::Cdr;
using eprosima::fastcdr::FastBuffer;
using eprosima::fastrtps::rtps::InstanceHandle_t;
using eprosima::fastrtps::rtps::ParticipantDiscoveryInfo;
using eprosima::fastrtps::rtps::SerializedPayload_t;

namespace {

std::mutex out_mutex;

void say(const std::string& line) {
    std::lock_guard<std::mutex> lock(out_mutex);
    std::cout << line << std::endl;
}

double monotonic_s() {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + ts.tv_nsec * 1e-9;
}

// sensor_msgs/JointState: std_msgs/Header (builtin_interfaces/Time stamp, string frame_id),
// string[] name, float64[] position, velocity, effort.
struct JointState {
    int32_t sec = 0;
    uint32_t nanosec = 0;
    std::string frame_id;
    std::vector<std::string> name;
    std::vector<double> position, velocity, effort;

    void serialize(Cdr& c) const {
        c << sec << nanosec << frame_id << name << position << velocity << effort;
    }
    void deserialize(Cdr& c) {
        c >> sec >> nanosec >> frame_id >> name >> position >> velocity >> effort;
    }
    size_t max_size() const {
        size_t n = 64 + frame_id.size();
        for (const auto& s : name) n += 8 + s.size();
        return n + 8 * (position.size() + velocity.size() + effort.size()) + 32;
    }
};

// std_msgs/Bool.
struct Bool {
    bool data = false;
    void serialize(Cdr& c) const { c << data; }
    void deserialize(Cdr& c) { c >> data; }
    size_t max_size() const { return 8; }
};

// A keyless type of ROS 2's DDS type name, encoded as plain CDR with its encapsulation header.
template <class T>
class RosType : public TopicDataType {
public:
    explicit RosType(const char* dds_name) {
        setName(dds_name);
        m_typeSize = 4096;
        m_isGetKeyDefined = false;
    }
    bool serialize(void* data, SerializedPayload_t* payload) override {
        FastBuffer buffer(reinterpret_cast<char*>(payload->data), payload->max_size);
        Cdr cdr(buffer, Cdr::DEFAULT_ENDIAN, Cdr::DDS_CDR);
        payload->encapsulation = cdr.endianness() == Cdr::BIG_ENDIANNESS ? CDR_BE : CDR_LE;
        try {
            cdr.serialize_encapsulation();
            static_cast<T*>(data)->serialize(cdr);
        } catch (...) {
            return false;
        }
        payload->length = static_cast<uint32_t>(cdr.getSerializedDataLength());
        return true;
    }
    bool deserialize(SerializedPayload_t* payload, void* data) override {
        FastBuffer buffer(reinterpret_cast<char*>(payload->data), payload->length);
        Cdr cdr(buffer, Cdr::DEFAULT_ENDIAN, Cdr::DDS_CDR);
        try {
            cdr.read_encapsulation();
            static_cast<T*>(data)->deserialize(cdr);
        } catch (...) {
            return false;
        }
        return true;
    }
    std::function<uint32_t()> getSerializedSizeProvider(void* data) override {
        return [data]() { return static_cast<uint32_t>(4 + static_cast<T*>(data)->max_size()); };
    }
    void* createData() override { return new T(); }
    void deleteData(void* data) override { delete static_cast<T*>(data); }
    bool getKey(void*, InstanceHandle_t*, bool) override { return false; }
};

class ParticipantEvents : public DomainParticipantListener {
public:
    void on_participant_discovery(DomainParticipant*, ParticipantDiscoveryInfo&& info) override {
        const char* what = "changed";
        switch (info.status) {
            case ParticipantDiscoveryInfo::DISCOVERED_PARTICIPANT: what = "discovered"; break;
            case ParticipantDiscoveryInfo::REMOVED_PARTICIPANT: what = "removed"; break;
            case ParticipantDiscoveryInfo::DROPPED_PARTICIPANT: what = "dropped"; break;
            default: break;
        }
        std::ostringstream line;
        line.precision(17);
        line << "participant " << what << " " << monotonic_s();
        say(line.str());
    }
};

template <class T>
std::vector<T> read_list(std::istream& in) {
    size_t n = 0;
    in >> n;
    std::vector<T> v(n);
    for (auto& x : v) in >> x;
    return v;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 5) {
        std::cerr << "usage: fastdds_peer <domain> <namespace> <heartbeat period ms> <depth>\n";
        return 2;
    }
    const int domain = std::stoi(argv[1]);
    const std::string ns = argv[2];
    const int heartbeat_ms = std::stoi(argv[3]);
    const int depth = std::stoi(argv[4]);

    // The participant's listener gets only discovery callbacks (no status bits): with status
    // bits it would take the readers' data-available callbacks away from them.
    ParticipantEvents events;
    DomainParticipant* dp = DomainParticipantFactory::get_instance()->create_participant(
        domain, PARTICIPANT_QOS_DEFAULT, &events, StatusMask::none());
    if (dp == nullptr) {
        std::cerr << "fastdds_peer: cannot create the participant\n";
        return 1;
    }
    TypeSupport joint_state_type(new RosType<JointState>("sensor_msgs::msg::dds_::JointState_"));
    TypeSupport bool_type(new RosType<Bool>("std_msgs::msg::dds_::Bool_"));
    joint_state_type.register_type(dp);
    bool_type.register_type(dp);

    Topic* states_topic = dp->create_topic("rt" + ns + "/joint_states",
                                           joint_state_type.get_type_name(), TOPIC_QOS_DEFAULT);
    Topic* commands_topic = dp->create_topic(
        "rt" + ns + "/joint_commands", joint_state_type.get_type_name(), TOPIC_QOS_DEFAULT);
    Topic* enable_topic =
        dp->create_topic("rt" + ns + "/enable", bool_type.get_type_name(), TOPIC_QOS_DEFAULT);

    // rclcpp::SensorDataQoS for joint_states: best effort, volatile, keep last 5.
    Subscriber* sub = dp->create_subscriber(SUBSCRIBER_QOS_DEFAULT);
    DataReaderQos rq = DATAREADER_QOS_DEFAULT;
    rq.reliability().kind = BEST_EFFORT_RELIABILITY_QOS;
    rq.durability().kind = VOLATILE_DURABILITY_QOS;
    rq.history().kind = KEEP_LAST_HISTORY_QOS;
    rq.history().depth = 5;
    DataReader* states = sub->create_datareader(states_topic, rq);

    // Reliable and volatile, as ROS 2 publishes by default: keep last 1 is rclcpp::QoS(1), as
    // topic_based_ros2_control publishes joint commands; keep last 10 is rclcpp's default.
    // The heartbeat period is the test's: a writer that announces its samples rarely shows
    // whether the reader acknowledges them by itself.
    Publisher* pub = dp->create_publisher(PUBLISHER_QOS_DEFAULT);
    DataWriterQos wq = DATAWRITER_QOS_DEFAULT;
    wq.reliability().kind = RELIABLE_RELIABILITY_QOS;
    wq.durability().kind = VOLATILE_DURABILITY_QOS;
    wq.history().kind = KEEP_LAST_HISTORY_QOS;
    wq.history().depth = depth;
    wq.reliable_writer_qos().times.heartbeatPeriod =
        eprosima::fastrtps::Duration_t(heartbeat_ms / 1000, (heartbeat_ms % 1000) * 1000000u);
    DataWriter* commands = pub->create_datawriter(commands_topic, wq);
    DataWriter* enable = pub->create_datawriter(enable_topic, wq);
    if (states == nullptr || commands == nullptr || enable == nullptr) {
        std::cerr << "fastdds_peer: cannot create the readers and writers\n";
        return 1;
    }

    JointState newest;
    bool have_state = false;
    DataWriter* last_writer = nullptr;
    double last_write = 0.0;
    std::string line;
    while (std::getline(std::cin, line)) {
        std::istringstream in(line);
        std::string verb;
        in >> verb;
        if (verb == "state") {
            JointState s;
            SampleInfo info;
            int taken = 0;
            while (states->take_next_sample(&s, &info) == ReturnCode_t::RETCODE_OK) {
                if (info.valid_data) {
                    newest = s;
                    have_state = true;
                    ++taken;
                }
            }
            if (!have_state) {
                say("state none");
                continue;
            }
            std::ostringstream o;
            o.precision(17);
            o << "state " << taken << " " << newest.sec << " " << newest.nanosec << " "
              << newest.name.size();
            for (const auto& n : newest.name) o << " " << n;
            for (const auto* v : {&newest.position, &newest.velocity, &newest.effort}) {
                if (v->size() != newest.name.size()) {
                    o << " (an array of " << v->size() << " values)";
                    continue;
                }
                for (double x : *v) o << " " << x;
            }
            say(o.str());
        } else if (verb == "cmd") {
            JointState c;
            c.name = read_list<std::string>(in);
            c.position = read_list<double>(in);
            c.velocity = read_list<double>(in);
            c.effort = read_list<double>(in);
            last_writer = commands;
            last_write = monotonic_s();
            say(commands->write(&c) ? "ok" : "write failed");
        } else if (verb == "enable") {
            int value = 0;
            in >> value;
            Bool b;
            b.data = value != 0;
            last_writer = enable;
            last_write = monotonic_s();
            say(enable->write(&b) ? "ok" : "write failed");
        } else if (verb == "ack") {
            int timeout_ms = 0;
            in >> timeout_ms;
            if (last_writer == nullptr) {
                say("ack nothing-written 0");
                continue;
            }
            ReturnCode_t rc = last_writer->wait_for_acknowledgments(eprosima::fastrtps::Duration_t(
                timeout_ms / 1000, (timeout_ms % 1000) * 1000000u));
            long us = static_cast<long>((monotonic_s() - last_write) * 1e6);
            say(std::string(rc == ReturnCode_t::RETCODE_OK ? "ack ok " : "ack timeout ") +
                std::to_string(us));
        } else if (verb == "matched") {
            PublicationMatchedStatus c{}, e{};
            SubscriptionMatchedStatus s{};
            commands->get_publication_matched_status(c);
            enable->get_publication_matched_status(e);
            states->get_subscription_matched_status(s);
            say("matched " + std::to_string(c.current_count) + " " +
                std::to_string(e.current_count) + " " + std::to_string(s.current_count));
        } else if (verb == "quit") {
            break;
        } else {
            say("unknown request: " + line);
        }
    }
    dp->delete_contained_entities();
    DomainParticipantFactory::get_instance()->delete_participant(dp);
    return 0;
}
