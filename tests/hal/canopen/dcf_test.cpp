// Tests of hal/canopen/dcf: the shipped DCFs read and resolved for a node, CiA 306 numbers
// ($NODEID expressions, hex, octal, negatives), and every error located at its file, line,
// section and key.
#include "numen/hal/canopen/dcf.hpp"

#include <gtest/gtest.h>

#include <string>

namespace {

using numen::hal::CanopenDataType;
using numen::hal::Dcf;
using numen::hal::DcfAccess;
using numen::hal::DcfError;
using numen::hal::DcfEntry;
using numen::hal::parse_dcf_file;
using numen::hal::parse_dcf_text;

std::string shipped(const char* name) { return std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/devices/" + name; }

// A small DCF; line numbers matter to the tests (line 1 is the [DeviceInfo] header).
constexpr const char* kSmall =
    "[DeviceInfo]\n"                      // 1
    "VendorNumber=0x0000ABCD\n"           // 2
    "ProductNumber=1026\n"                // 3
    "[OptionalObjects]\n"                 // 4
    "SupportedObjects=3\n"                // 5
    "1=0x1017\n"                          // 6
    "2=0x1800\n"                          // 7
    "3=0x6071\n"                          // 8
    "[1017]\n"                            // 9
    "ParameterName=Producer heartbeat\n"  // 10
    "DataType=0x0006\n"                   // 11
    "AccessType=rw\n"                     // 12
    "DefaultValue=0\n"                    // 13
    "ParameterValue=012\n"                // 14  octal: 10
    "[1800]\n"                            // 15
    "ObjectType=0x9\n"                    // 16
    "SubNumber=2\n"                       // 17
    "[1800sub0]\n"                        // 18
    "DataType=0x0005\n"                   // 19
    "AccessType=ro\n"                     // 20
    "DefaultValue=2\n"                    // 21
    "[1800sub1]\n"                        // 22
    "DataType=0x0007\n"                   // 23
    "AccessType=rw\n"                     // 24
    "ParameterValue=0x180+$NODEID\n"      // 25
    "[6071]\n"                            // 26
    "DataType=0x0003\n"                   // 27
    "AccessType=rww\n"                    // 28
    "PDOMapping=1\n"                      // 29
    "DefaultValue=-250\n";                // 30

/// `text` with line `line` (1-based) replaced by `replacement` (which may hold several lines).
std::string with_line(std::string text, int line, const std::string& replacement) {
  std::size_t b = 0;
  for (int i = 1; i < line; ++i) b = text.find('\n', b) + 1;
  const std::size_t e = text.find('\n', b);
  return text.replace(b, e - b, replacement);
}

/// Parses `text` expecting a DcfError; returns it.
DcfError error_of(const std::string& text, std::uint8_t node = 5) {
  try {
    (void)parse_dcf_text(text, "node.dcf", node);
  } catch (const DcfError& e) {
    return e;
  }
  ADD_FAILURE() << "no DcfError for:\n" << text;
  return DcfError({}, "none");
}

TEST(Dcf, SmallFileValuesAndTypes) {
  const Dcf d = parse_dcf_text(kSmall, "node.dcf", 5);
  EXPECT_EQ(d.device_info.vendor_number, 0xABCDu);
  EXPECT_EQ(d.device_info.product_number, 1026u);
  ASSERT_EQ(d.entries.size(), 4u);
  const DcfEntry* hb = d.find({0x1017, 0});
  ASSERT_NE(hb, nullptr);
  EXPECT_TRUE(hb->configured);
  EXPECT_EQ(hb->value, 10u);  // ParameterValue 012 is octal
  EXPECT_EQ(hb->access, DcfAccess::kReadWrite);
  EXPECT_EQ(hb->location.line, 14);
  EXPECT_EQ(hb->location.key, "ParameterValue");
  const DcfEntry* cob = d.find({0x1800, 1});
  ASSERT_NE(cob, nullptr);
  EXPECT_EQ(cob->value, 0x185u);  // 0x180 + $NODEID, node 5
  EXPECT_EQ(cob->location.section, "1800sub1");
  const DcfEntry* torque = d.find({0x6071, 0});
  ASSERT_NE(torque, nullptr);
  EXPECT_FALSE(torque->configured);
  EXPECT_TRUE(torque->has_default);
  EXPECT_EQ(torque->value, 0xFF06u);  // -250 as INTEGER16 bits
  EXPECT_TRUE(torque->pdo_mappable);
  EXPECT_EQ(torque->access, DcfAccess::kReadWriteWrite);
  EXPECT_EQ(d.find({0x1800, 2}), nullptr);
}

TEST(Dcf, ShippedDriveResolvedForItsNode) {
  const Dcf d = parse_dcf_file(shipped("trocar_drive.dcf"), 2);
  EXPECT_EQ(d.device_info.product_number, 0x402u);
  EXPECT_FALSE(d.node_id.has_value());
  EXPECT_EQ(d.find({0x1400, 1})->value, 0x202u);
  EXPECT_EQ(d.find({0x1800, 1})->value, 0x182u);
  EXPECT_EQ(d.find({0x1801, 1})->value, 0x282u);
  EXPECT_EQ(d.find({0x1A01, 1})->value, 0x60410010u);
  EXPECT_EQ(d.find({0x6060, 0})->value, 10u);
  EXPECT_EQ(d.find({0x6060, 0})->data_type, CanopenDataType::kInteger8);
  EXPECT_EQ(d.find({0x6072, 0})->value, 2000u);
  EXPECT_EQ(d.find({0x1018, 4})->value, 2u);  // serial number $NODEID
  EXPECT_EQ(d.find({0x1008, 0})->text, "numen emulated drive");
  const Dcf e = parse_dcf_file(shipped("encoder.dcf"), 6);
  EXPECT_EQ(e.find({0x1800, 1})->value, 0x186u);
  EXPECT_EQ(e.find({0x1400, 1}), nullptr);
  const Dcf p = parse_dcf_file(shipped("phantom_drive.dcf"), 1);
  EXPECT_EQ(p.find({0x6072, 0})->value, 4000u);
}

TEST(Dcf, NamesAreCaseInsensitiveAndCommissioningNodeIdIsChecked) {
  std::string t = with_line(kSmall, 11, "datatype=0x0006");
  t = with_line(t, 14, "PARAMETERVALUE=$nodeid+1");
  EXPECT_EQ(parse_dcf_text(t, "node.dcf", 5).find({0x1017, 0})->value, 6u);
  const std::string fixed = std::string(kSmall) + "[DeviceComissioning]\nNodeID=5\n";
  EXPECT_EQ(parse_dcf_text(fixed, "node.dcf", 5).node_id, 5);
  const DcfError e = error_of(fixed, 6);
  EXPECT_EQ(e.location().line, 32);
  EXPECT_EQ(e.location().key, "NodeID");
  EXPECT_NE(std::string(e.what()).find("configures node 5, the scene gives node 6"), std::string::npos);
}

struct BadCase {
  const char* name;
  int line;                 // line to replace in kSmall (0: append)
  const char* replacement;
  int error_line;
  const char* section;
  const char* key;
  const char* message;      // part of the message
};

TEST(Dcf, EveryErrorIsLocated) {
  const BadCase cases[] = {
      {"syntax", 12, "AccessType rw", 12, "", "", "not an INI line"},
      {"duplicate key", 13, "DefaultValue=0\nDataType=0x0007", 14, "1017", "DataType", "key given twice"},
      {"duplicate section", 0, "[1017]\nDataType=0x0006", 31, "1017", "", "section given twice"},
      {"missing data type", 11, "; no data type", 9, "1017", "DataType", "missing"},
      {"unknown data type", 11, "DataType=0x0010", 11, "1017", "DataType", "not a data type numen reads"},
      {"bad access", 12, "AccessType=rx", 12, "1017", "AccessType", "not ro, wo, rw, rwr, rww or const"},
      {"not a number", 14, "ParameterValue=12z", 14, "1017", "ParameterValue", "is not a number"},
      {"out of range", 14, "ParameterValue=70000", 14, "1017", "ParameterValue", "does not fit the data type"},
      {"negative unsigned", 14, "ParameterValue=-1", 14, "1017", "ParameterValue", "does not fit"},
      {"negative in expression", 25, "ParameterValue=$NODEID+-1", 25, "1800sub1", "ParameterValue", "negative"},
      {"node id twice", 25, "ParameterValue=$NODEID+$NODEID", 25, "1800sub1", "ParameterValue", "$NODEID given twice"},
      {"bad default under a value", 13, "DefaultValue=0x1FFFF", 13, "1017", "DefaultValue", "does not fit"},
      {"sub count", 17, "SubNumber=3", 17, "1800", "SubNumber", "3 sub-indices announced, 2"},
      {"object type", 16, "ObjectType=0x5", 16, "1800", "ObjectType", "is not 0x7"},
      {"compact", 17, "SubNumber=2\nCompactSubObj=2", 18, "1800", "CompactSubObj", "compact sub-objects"},
      {"listed without section", 8, "3=0x6072", 8, "OptionalObjects", "3", "0x6072 is listed"},
      {"orphan sub-index", 0, "[2000sub1]\nDataType=0x0005\nAccessType=ro", 31, "2000sub1", "", "without its object section"},
      {"sub-index of a VAR", 0, "[1017sub1]\nDataType=0x0005\nAccessType=ro", 31, "1017sub1", "", "VAR object"},
      {"boolean", 27, "DataType=0x0001", 30, "6071", "DefaultValue", "does not fit"},
      {"domain value", 27, "DataType=0x000F\nParameterValue=00AA", 28, "6071", "ParameterValue", "DOMAIN"},
  };
  for (const BadCase& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string text = c.line == 0 ? std::string(kSmall) + c.replacement + "\n"
                                         : with_line(kSmall, c.line, c.replacement);
    const DcfError e = error_of(text);
    EXPECT_EQ(e.location().file, "node.dcf");
    EXPECT_EQ(e.location().line, c.error_line);
    EXPECT_EQ(e.location().section, c.section);
    EXPECT_EQ(e.location().key, c.key);
    EXPECT_NE(e.message().find(c.message), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).rfind("node.dcf:" + std::to_string(c.error_line) + ":", 0), 0u) << e.what();
  }
}

TEST(Dcf, LongLineAndUnreadableFile) {
  const DcfError e = error_of(with_line(kSmall, 10, "ParameterName=" + std::string(300, 'x')));
  EXPECT_EQ(e.location().line, 10);
  EXPECT_NE(e.message().find("longer than"), std::string::npos);
  try {
    (void)parse_dcf_file("/nonexistent/node.dcf", 1);
    ADD_FAILURE() << "no error";
  } catch (const DcfError& x) {
    EXPECT_EQ(x.location().file, "/nonexistent/node.dcf");
    EXPECT_EQ(x.location().line, 0);
    EXPECT_NE(x.message().find("cannot open"), std::string::npos);
  }
  EXPECT_THROW((void)parse_dcf_text(kSmall, "node.dcf", 0), DcfError);
  EXPECT_THROW((void)parse_dcf_text(kSmall, "node.dcf", 128), DcfError);
}

}  // namespace
