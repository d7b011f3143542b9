#pragma once
/// @file dcf.hpp
/// CiA 306 electronic data sheets (EDS) and device configuration files (DCF): INI files that
/// describe a CANopen node's object dictionary — one section per object ([1018]) and per
/// sub-index of an ARRAY or RECORD ([1018sub2]), with its ParameterName, ObjectType,
/// DataType, AccessType, DefaultValue, and in a DCF the configured ParameterValue — plus the
/// [FileInfo], [DeviceInfo] and [DeviceComissioning] sections. numen reads them to configure a
/// node over SDO at bring-up (dcf_configuration.hpp; docs/sdo.md).
///
/// Parsed with libinih (no hand-written INI reader). What numen reads (CiA 306 §4):
///  - numbers in decimal, hexadecimal (0x…) or octal (leading 0), negative decimals for the
///    INTEGERn types, and the node-id expressions `$NODEID`, `$NODEID+N` and `N+$NODEID`
///    (resolved with the node id the scene gives the node);
///  - ObjectType 0x7 (VAR), 0x8 (ARRAY), 0x9 (RECORD); ARRAY/RECORD objects with SubNumber and
///    one [XXXXsubN] section per sub-index (CompactSubObj is refused, as are DOMAIN objects
///    with a value);
///  - the data types BOOLEAN, INTEGER8/16/32/64, UNSIGNED8/16/32/64, REAL32 (as its bits),
///    VISIBLE_STRING, OCTET_STRING, UNICODE_STRING and DOMAIN (strings kept as text);
///  - the object lists ([MandatoryObjects], [OptionalObjects], [ManufacturerObjects]): every
///    listed object must have its section.
/// Section and key names are case-insensitive (CiA 306). Every error is a DcfError naming the
/// file, the line, the section and the key. Setup code: allocates and throws.

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "numen/hal/canopen/sdo.hpp"

namespace numen::hal {

/// CiA 301 data type codes (object 0x0001–0x001B, "DataType" in an EDS/DCF) numen reads.
struct CanopenDataType {
  static constexpr std::uint16_t kBoolean = 0x0001;
  static constexpr std::uint16_t kInteger8 = 0x0002;
  static constexpr std::uint16_t kInteger16 = 0x0003;
  static constexpr std::uint16_t kInteger32 = 0x0004;
  static constexpr std::uint16_t kUnsigned8 = 0x0005;
  static constexpr std::uint16_t kUnsigned16 = 0x0006;
  static constexpr std::uint16_t kUnsigned32 = 0x0007;
  static constexpr std::uint16_t kReal32 = 0x0008;
  static constexpr std::uint16_t kVisibleString = 0x0009;
  static constexpr std::uint16_t kOctetString = 0x000A;
  static constexpr std::uint16_t kUnicodeString = 0x000B;
  static constexpr std::uint16_t kDomain = 0x000F;
  static constexpr std::uint16_t kInteger64 = 0x0015;
  static constexpr std::uint16_t kUnsigned64 = 0x001B;
};

/// Bytes a value of numeric data type `type` has on the bus (1, 2, 4 or 8); 0 for the string
/// types, DOMAIN and a code numen does not read.
std::size_t data_type_size(std::uint16_t type) noexcept;
/// True for INTEGER8/16/32/64.
bool data_type_signed(std::uint16_t type) noexcept;

/// AccessType of an entry (CiA 306): ro, wo, rw, rwr (rw, mapped to a TPDO), rww (rw, mapped
/// to an RPDO), const.
enum class DcfAccess : std::uint8_t { kReadOnly, kWriteOnly, kReadWrite, kReadWriteRead, kReadWriteWrite, kConst };

/// True for wo, rw, rwr, rww: an SDO download may write the entry.
constexpr bool writable(DcfAccess a) noexcept {
  return a == DcfAccess::kWriteOnly || a == DcfAccess::kReadWrite ||
         a == DcfAccess::kReadWriteRead || a == DcfAccess::kReadWriteWrite;
}

/// Where something is in an EDS/DCF: file, 1-based line, section and key (either may be
/// empty, e.g. for a missing section).
struct DcfLocation {
  std::string file;
  int line = 0;
  std::string section;  ///< As written in the file, without brackets.
  std::string key;
};

/// "file:line: [section] key" (the parts that are set).
std::string to_string(const DcfLocation& location);

/// A malformed or inconsistent EDS/DCF. what() = "file:line: [section] key: message".
class DcfError : public std::runtime_error {
 public:
  DcfError(DcfLocation location, const std::string& message);
  /// Where.
  const DcfLocation& location() const noexcept { return location_; }
  /// The message without the location.
  const std::string& message() const noexcept { return message_; }

 private:
  DcfLocation location_;
  std::string message_;
};

/// One object dictionary entry (a VAR object, or one sub-index of an ARRAY / RECORD).
struct DcfEntry {
  SdoAddress address;
  std::string name;              ///< ParameterName.
  std::uint16_t data_type = 0;   ///< CanopenDataType code.
  DcfAccess access = DcfAccess::kReadOnly;
  bool pdo_mappable = false;     ///< PDOMapping=1.
  bool has_default = false;      ///< DefaultValue given (and not empty).
  bool configured = false;       ///< ParameterValue given: the DCF's configured value.
  /// Numeric types: the ParameterValue if configured, else the DefaultValue, node-id
  /// expressions resolved, as the unsigned bits of the data type's size (two's complement of
  /// a negative INTEGERn; data_type_size() bytes little endian on the bus).
  std::uint64_t value = 0;
  /// String types and DOMAIN: the value's text as written.
  std::string text;
  /// The line of ParameterValue if configured, else of DefaultValue, else of the section.
  DcfLocation location;
};

/// [FileInfo] (the fields numen reports).
struct DcfFileInfo {
  std::string file_name, description, created_by, eds_version;
};

/// [DeviceInfo] (the fields numen reports and checks).
struct DcfDeviceInfo {
  std::string vendor_name, product_name;
  std::uint32_t vendor_number = 0, product_number = 0, revision_number = 0;
};

/// A parsed EDS or DCF, its values resolved for one node id.
struct Dcf {
  std::string path;              ///< As given to the parser (used in every message).
  DcfFileInfo file_info;
  DcfDeviceInfo device_info;
  /// [DeviceComissioning] NodeID, if the file fixes one (a DCF of one node).
  std::optional<std::uint8_t> node_id;
  /// The node id the values were resolved with.
  std::uint8_t resolved_node_id = 0;
  /// Every entry, sorted by index then sub-index.
  std::vector<DcfEntry> entries;

  /// The entry at `address`, nullptr if the file has none.
  const DcfEntry* find(SdoAddress address) const noexcept;
};

/// Parses the EDS/DCF at `path`, resolving $NODEID with `node_id` (1–127). Throws DcfError
/// (file unreadable: line 0; syntax error: the line libinih reports; every semantic error: the
/// line of the key or section). A [DeviceComissioning] NodeID different from `node_id` is an
/// error (the file configures another node).
Dcf parse_dcf_file(const std::string& path, std::uint8_t node_id);

/// The same from `text`, reported as file `name`.
Dcf parse_dcf_text(std::string_view text, const std::string& name, std::uint8_t node_id);

}  // namespace numen::hal
