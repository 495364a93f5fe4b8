#include "proto/text_file.h"

#include <google/protobuf/io/tokenizer.h>

#include <fstream>
#include <sstream>
#include <stdexcept>

namespace doppel::proto {
namespace {

using google::protobuf::Descriptor;
using google::protobuf::FieldDescriptor;
using google::protobuf::Message;
using google::protobuf::Reflection;
using google::protobuf::TextFormat;

// Collects the first syntax error with its position (protobuf lines and columns are 0-based).
class FirstError : public google::protobuf::io::ErrorCollector {
 public:
  void AddError(int line, int column, const std::string& message) override {
    if (message_.empty()) {
      message_ = std::to_string(line + 1) + ":" + std::to_string(column + 1) + ": " + message;
    }
  }
  void AddWarning(int, int, const std::string&) override {}
  const std::string& message() const { return message_; }

 private:
  std::string message_;
};

std::string position_text(const TextFormat::ParseLocation& where) {
  return std::to_string(where.line + 1) + ":" + std::to_string(where.column + 1);
}

}  // namespace

std::string TextFile::read(const std::string& path, std::string_view what) {
  std::ifstream in(path);
  if (!in) {
    throw std::runtime_error(path + ": cannot read " + std::string(what));
  }
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

void TextFile::parse_into(std::unique_ptr<Message> message, std::string_view text, const std::string& path) {
  path_ = path;
  message_ = std::move(message);
  tree_ = std::make_unique<TextFormat::ParseInfoTree>();
  nodes_.clear();
  FirstError errors;
  TextFormat::Parser parser;
  parser.RecordErrorsTo(&errors);
  parser.WriteLocationsTo(tree_.get());
  if (!parser.ParseFromString(std::string(text), message_.get())) {
    throw std::runtime_error(path + ":" + errors.message());
  }
  index_locations(*message_, tree_.get(), "1:1");
}

void TextFile::index_locations(const Message& message, const TextFormat::ParseInfoTree* tree, std::string position) {
  nodes_[&message] = Node{tree, std::move(position)};
  const Descriptor* descriptor = message.GetDescriptor();
  const Reflection* reflection = message.GetReflection();
  for (int f = 0; f < descriptor->field_count(); ++f) {
    const FieldDescriptor* field = descriptor->field(f);
    if (field->cpp_type() != FieldDescriptor::CPPTYPE_MESSAGE) {
      continue;
    }
    if (field->is_repeated()) {
      for (int i = 0; i < reflection->FieldSize(message, field); ++i) {
        index_locations(reflection->GetRepeatedMessage(message, field, i), tree->GetTreeForNested(field, i),
                        position_text(tree->GetLocation(field, i)));
      }
    } else if (reflection->HasField(message, field)) {
      index_locations(reflection->GetMessage(message, field), tree->GetTreeForNested(field, -1),
                      position_text(tree->GetLocation(field, -1)));
    }
  }
}

std::string TextFile::location(const Message& message, std::string_view field, int index) const {
  auto node = nodes_.find(&message);
  if (node == nodes_.end()) {
    return path_;
  }
  const FieldDescriptor* descriptor = message.GetDescriptor()->FindFieldByName(std::string(field));
  bool present = descriptor != nullptr &&
                 (descriptor->is_repeated()
                      ? index >= 0 && index < message.GetReflection()->FieldSize(message, descriptor)
                      : index < 0);
  if (present && node->second.tree != nullptr) {
    TextFormat::ParseLocation where = node->second.tree->GetLocation(descriptor, index);
    if (where.line >= 0) {
      return path_ + ":" + position_text(where);
    }
  }
  return path_ + ":" + node->second.position;
}

void TextFile::fail(const Message& message, std::string_view field, int index, std::string_view what) const {
  std::string field_path = message.GetDescriptor()->name() + "." + std::string(field);
  if (index >= 0) {
    field_path += "[" + std::to_string(index) + "]";
  }
  throw std::invalid_argument(location(message, field, index) + ": " + field_path + ": " + std::string(what));
}

}  // namespace doppel::proto
